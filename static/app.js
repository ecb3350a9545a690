// MillBlocks editor behaviour: keyboard conversation, export options, verify panel.
// The preview (zoom, pan, linking drawing and blocks) is static/preview.js.
// No inline script anywhere (the Content-Security-Policy forbids it): everything is here.
(function () {
  "use strict";

  // The prompts Enter steps through: every value of the block (ABS/INC is not one: it is
  // the INC key at the X or Y prompt, as on the control).
  function fields(form) {
    return Array.from(form.querySelectorAll("[data-field]")).filter(function (el) {
      return !el.disabled && el.type !== "hidden";
    });
  }

  // A new block's form shows the values offered; until one is typed, Enter on the last
  // prompt does not enter it (a stray Enter saved unwanted blocks). Ctrl+Enter does.
  function untouched(form) {
    if (form.getAttribute("data-offered") !== "1") { return false; }
    var mode = form.querySelector("[data-mode]");
    if (mode && mode.value !== mode.defaultValue) { return false; }
    return fields(form).every(function (el) {
      if (el.type === "checkbox") { return el.checked === el.defaultChecked; }
      if (el.tagName === "SELECT") {
        return Array.from(el.options).every(function (o) { return o.selected === o.defaultSelected; });
      }
      return el.value === el.defaultValue;
    });
  }

  function enterBlock(form) {
    var submit = form.querySelector("[data-submit]");
    if (submit) { submit.click(); } else { form.requestSubmit(); }
  }

  // The INC key: ABS/INC of the block, shown in its heading; new blocks take it on.
  function toggleMode(form) {
    var mode = form.querySelector("[data-mode]");
    var key = form.querySelector("[data-mode-key]");
    if (!mode || !key) { return; }
    if (key.getAttribute("data-inc-only") === "1") {
      key.classList.add("refused");
      key.title = "blocks in a LOOP sequence are always INC";
      return;
    }
    mode.value = mode.value === "inc" ? "abs" : "inc";
    key.textContent = mode.value.toUpperCase();
  }

  document.addEventListener("click", function (event) {
    var key = event.target.closest ? event.target.closest("[data-mode-key]") : null;
    if (key && key.form) { toggleMode(key.form); }
  });

  // Alt+letter reaches the element with that access key on every browser (browsers disagree
  // on the modifier, and some headless ones have none): a field gets the focus, anything
  // else is clicked.
  document.addEventListener("keydown", function (event) {
    if (!event.altKey || event.ctrlKey || event.metaKey || event.key.length !== 1) { return; }
    var el = document.querySelector('[accesskey="' + event.key.toLowerCase() + '"]');
    if (!el) { return; }
    event.preventDefault();
    if (/^(INPUT|SELECT|TEXTAREA)$/.test(el.tagName) && el.type !== "checkbox") { el.focus(); }
    else { el.click(); }
  }, true);

  // Enter moves to the next prompt, as ENTER ADV does on the control; on the last one it
  // enters the block. Escape goes back one step (leaving a block unsaved).
  document.addEventListener("keydown", function (event) {
    var target = event.target;
    var form = target.closest ? target.closest("form.block-form, form.db0-form") : null;
    if (event.key === "Enter" && (event.ctrlKey || event.metaKey) && target.form) {
      // Ctrl+Enter enters the whole form from any prompt.
      event.preventDefault();
      enterBlock(target.form);
      return;
    }
    if (event.key === "Enter" && target.matches && target.matches("#entry .choices")) {
      // On a menu a number chooses; Enter does nothing (it opened POS by accident).
      event.preventDefault();
      return;
    }
    if (event.key === "Enter" && form && target.tagName !== "TEXTAREA" && target.tagName !== "BUTTON") {
      var list = fields(form);
      var index = list.indexOf(target);
      if (index >= 0 && index < list.length - 1) {
        event.preventDefault();
        list[index + 1].focus();
        if (list[index + 1].select) { list[index + 1].select(); }
      } else if (index === list.length - 1) {
        event.preventDefault();
        var note = form.querySelector(".untouched");
        if (untouched(form)) { if (note) { note.hidden = false; } return; }
        enterBlock(form);
      }
      return;
    }
    if (form && target.matches("[data-xy]") && (event.key === "i" || event.key === "I") &&
        !event.ctrlKey && !event.metaKey && !event.altKey) {
      event.preventDefault();
      toggleMode(form);
      return;
    }
    if (form && target.matches("select[data-numbered]") && /^[0-9]$/.test(event.key)) {
      // A choice prompt takes its number and moves on, as the control's menus do.
      var option = Array.from(target.options).find(function (o) {
        return o.textContent.trim().split(" ")[0] === event.key;
      });
      if (option) {
        event.preventDefault();
        target.value = option.value;
        var all = fields(form);
        var next = all[all.indexOf(target) + 1];
        if (next) { next.focus(); if (next.select) { next.select(); } }
      }
      return;
    }
    var typing = target.tagName === "INPUT" || target.tagName === "SELECT" || target.tagName === "TEXTAREA";
    if (event.key === "Escape") {
      var back = document.querySelector("#entry [data-back]");
      if (back) { event.preventDefault(); back.click(); }
      return;
    }
    if (!typing && /^[0-9]$/.test(event.key)) {
      // 0 is the tenth choice (POCKET), as on a phone's keypad.
      var choice = document.querySelector('#entry .choice[data-key="' + event.key + '"]');
      if (choice) { event.preventDefault(); choice.click(); }
    }
  });

  // After htmx swaps a part of the editor in, put the cursor on the first prompt (or the
  // first choice), and keep the block list in step with the entry panel.
  var shownList = null;
  function focusEntry() {
    // On a menu the menu itself has the focus, so a stray Enter chooses nothing.
    var first = document.querySelector("#entry form.block-form .field [data-field]") ||
      document.querySelector("#entry .choices");
    if (first) { first.focus(); if (first.select) { first.select(); } }
    syncList();
    var blocks = document.getElementById("blocks");
    if (blocks !== shownList) { shownList = blocks; showFocus(); }
  }

  // The row of the block being edited (or "new block…" when entering at the end) is the
  // current one; the entry panel says which, since a choice swaps in the panel alone.
  function syncList() {
    var entry = document.getElementById("entry");
    if (!entry) { return; }
    var at = entry.getAttribute("data-at");
    var editing = entry.getAttribute("data-editing") === "1";
    document.querySelectorAll(".block-row.current").forEach(function (el) { el.classList.remove("current"); });
    var current = editing ? document.getElementById("b-" + at) :
      document.querySelector('.block-row.new[data-new="' + at + '"]');
    if (current) { current.classList.add("current"); }
  }

  // The list shows the block it was asked to stay at (the edited one) after it is drawn
  // anew: scrolled within the list, not the page.
  function showFocus() {
    var blocks = document.getElementById("blocks");
    var list = blocks && blocks.querySelector(".block-list");
    var row = blocks && document.getElementById("b-" + blocks.getAttribute("data-focus"));
    if (!list || !row) { return; }
    var top = row.getBoundingClientRect().top - list.getBoundingClientRect().top + list.scrollTop;
    if (top < list.scrollTop || top + row.offsetHeight > list.scrollTop + list.clientHeight) {
      list.scrollTop = Math.max(0, top - (list.clientHeight - row.offsetHeight) / 2);
    }
  }

  // Typing replaces a prompt's value, as on the control.
  document.addEventListener("focusin", function (event) {
    if (event.target.matches && event.target.matches("input[data-field]") && event.target.select) {
      event.target.select();
    }
  });

  document.addEventListener("htmx:after:swap", focusEntry);
  document.addEventListener("htmx:afterSwap", focusEntry);

  var reloadTimer = null;

  document.addEventListener("change", function (event) {
    if (event.target.matches("select[data-reload]")) {
      // Each target has its own options: reload the page for the chosen one, once the
      // choice settles (typing a name into the list selects on every letter).
      var select = event.target;
      clearTimeout(reloadTimer);
      reloadTimer = setTimeout(function () {
        var form = select.form;
        var url = new URL(form.action, location.href);
        url.searchParams.set("target", select.value);
        var machine = form.querySelector("select[name=machine]");
        if (machine && machine.value) { url.searchParams.set("machine", machine.value); }
        location.href = url.toString();
      }, 600);
    }
  });

  document.addEventListener("DOMContentLoaded", function () {
    var active = document.activeElement;
    if (active && active.matches("input[data-field]")) { active.select(); }
    focusEntry();
  });
  // Verify in the editor: opening the panel fetches the report per block (the simulation
  // runs on the server) and marks the rows of the blocks it names.
  document.addEventListener("toggle", function (event) {
    var panel = event.target;
    if (!panel.matches || !panel.matches("details.verify-panel") || !panel.open || panel.dataset.loaded) { return; }
    panel.dataset.loaded = "1";
    var body = panel.querySelector(".verify-body");
    fetch(panel.dataset.report, { credentials: "same-origin" }).then(function (response) {
      return response.text().then(function (text) { return { ok: response.ok, text: text }; });
    }).then(function (answer) {
      if (!answer.ok) { body.textContent = answer.text; return; }
      body.innerHTML = answer.text;
      body.querySelectorAll(".finding[data-block]").forEach(function (finding) {
        var row = document.querySelector('.block-row[data-block="' + finding.dataset.block + '"]');
        if (row) { row.classList.add("has-findings"); }
      });
      panel.dataset.state = "ready";
    });
  }, true);
})();
