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

  // Where the cursor goes after a choice typed on `el`: the next prompt of the Enter
  // sequence; from a prompt beside it (ENTRY), the next one beside it that is shown now
  // (its RAMP ANGLE), else nowhere (the cursor stays).
  function nextPrompt(form, el) {
    if (!el.hasAttribute("data-beside")) {
      var all = fields(form);
      return all[all.indexOf(el) + 1] || null;
    }
    var beside = Array.from(form.querySelectorAll("[data-beside]")).filter(function (other) {
      return !other.disabled;
    });
    return beside[beside.indexOf(el) + 1] || null;
  }

  // A new block's form shows the values offered; until one is typed, Enter on the last
  // prompt does not enter it (a stray Enter saved unwanted blocks). Ctrl+Enter does.
  function untouched(form) {
    if (form.getAttribute("data-offered") !== "1") { return false; }
    var mode = form.querySelector("[data-mode]");
    if (mode && mode.value !== mode.defaultValue) { return false; }
    // The prompts beside the sequence count too: a HELIX chosen is a value typed.
    var beside = Array.from(form.querySelectorAll("[data-beside]")).filter(function (el) {
      return !el.disabled;
    });
    return fields(form).concat(beside).every(function (el) {
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
  function shortcut(event) {
    if (!event.altKey || event.ctrlKey || event.metaKey || event.key.length !== 1) { return false; }
    var el = document.querySelector('[accesskey="' + event.key.toLowerCase() + '"]');
    if (!el) { return false; }
    event.preventDefault();
    if (/^(INPUT|SELECT|TEXTAREA)$/.test(el.tagName) && el.type !== "checkbox") { el.focus(); }
    else { el.click(); }
    return true;
  }

  // The menus are in the page: a type with sub-types shows its menu (a template the server
  // sent with the type menu) at once, and Esc or "back" shows the type menu again. A choice
  // that does not fit here says why, without asking the server.
  var typeMenu = null; // the type menu's nodes while a sub-type menu is shown in its place

  function showMenu(shown, nodes) {
    var entry = document.getElementById("entry");
    entry.querySelectorAll(".message.refused").forEach(function (el) { el.remove(); });
    shown.replaceChildren.apply(shown, nodes);
    if (window.htmx) { window.htmx.process(shown); }
    focusEntry();
  }

  document.addEventListener("click", function (event) {
    var link = event.target.closest ? event.target.closest("#entry a.choice, #entry a[data-menu-back]") : null;
    if (!link) { return; }
    var entry = document.getElementById("entry");
    var shown = entry.querySelector("[data-menu-shown]");
    if (link.classList.contains("unavailable")) {
      event.preventDefault();
      event.stopPropagation();
      entry.querySelectorAll(".message.refused").forEach(function (el) { el.remove(); });
      var note = document.createElement("p");
      note.className = "message error refused";
      note.setAttribute("role", "alert");
      note.textContent = link.title;
      entry.prepend(note);
      return;
    }
    if (!shown) { return; }
    if (link.hasAttribute("data-menu-back") && typeMenu) {
      event.preventDefault();
      event.stopPropagation();
      var nodes = typeMenu;
      typeMenu = null;
      showMenu(shown, nodes);
      return;
    }
    var menu = link.getAttribute("data-menu");
    var template = menu && entry.querySelector('template[data-menu="' + menu + '"]');
    if (!template) { return; }
    event.preventDefault();
    event.stopPropagation();
    typeMenu = Array.from(shown.childNodes);
    var nodes = template.content.cloneNode(true);
    // The template's choices name their kind; their links are made here (see _entry.html).
    var base = template.getAttribute("data-url") || "";
    nodes.querySelectorAll("a.choice[data-kind]").forEach(function (a) {
      var url = base + encodeURIComponent(a.getAttribute("data-kind"));
      a.setAttribute("href", url);
      a.setAttribute("hx-get", url);
    });
    showMenu(shown, Array.from(nodes.childNodes));
  }, true);

  // Enter moves to the next prompt, as ENTER ADV does on the control; on the last one it
  // enters the block. Escape goes back one step (leaving a block unsaved). Returns whether
  // the key was taken (else it does what it does in the browser).
  function editorKey(event) {
    var target = event.target;
    var form = target.closest ? target.closest("form.block-form, form.db0-form") : null;
    if (event.key === "Enter" && (event.ctrlKey || event.metaKey) && target.form) {
      // Ctrl+Enter enters the whole form from any prompt.
      event.preventDefault();
      enterBlock(target.form);
      return;
    }
    if (event.key === "Enter" && target.matches && target.matches("input.crib-pick")) {
      // Data Block 0's crib field: Enter picks the tool typed (the row is filled from the
      // crib), never submits the form.
      event.preventDefault();
      target.dispatchEvent(new Event("change", { bubbles: true }));
      return;
    }
    if (event.key === "Enter" && target.matches && target.matches("#entry .choices")) {
      // On a menu a number chooses; Enter does nothing (it opened POS by accident).
      event.preventDefault();
      return;
    }
    if (event.key === "Enter" && form && target.hasAttribute && target.hasAttribute("data-beside")) {
      // A prompt beside the sequence (ENTRY, its RAMP ANGLE) steps to the next one beside
      // it that is shown, and from the last enters the block as the last prompt does: the
      // browser's own Enter would submit the form past the check for untouched values.
      event.preventDefault();
      var beside = nextPrompt(form, target);
      if (beside) {
        beside.focus();
        if (beside.select) { beside.select(); }
        return;
      }
      var untouchedNote = form.querySelector(".untouched");
      if (untouched(form)) { if (untouchedNote) { untouchedNote.hidden = false; } return; }
      enterBlock(form);
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
        // As a choice made with the pointer: the prompts shown only for some values (a
        // PLACEMENT's ENTRY, an ENTRY's RAMP ANGLE) follow it, and so does the rest.
        target.dispatchEvent(new Event("change", { bubbles: true }));
        var next = nextPrompt(form, target);
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
    if (!typing && /^[0-9]$/.test(event.key) && !event.altKey && !event.ctrlKey && !event.metaKey) {
      // 0 is the tenth choice (POCKET), as on a phone's keypad.
      var choice = document.querySelector('#entry .choice[data-key="' + event.key + '"]');
      if (choice) { event.preventDefault(); choice.click(); }
    }
  }

  // No key is lost (issue 29): while the server answers a key (a block entered, a type
  // chosen), the keys typed after it wait here and are applied in order once its answer is
  // in the page, as the control takes keys typed ahead of its screen.
  var queue = [];
  var busy = 0; // requests for the editor's panels in flight
  var busySince = 0;
  var MODIFIERS = /^(Shift|Control|Alt|AltGraph|Meta|CapsLock|NumLock|Fn|OS)$/;

  function counted(ctx) {
    // The drawing (and the preview's parts) follow an edit on their own: no key waits on them.
    var source = ctx && ctx.sourceElement;
    return !(source && source.closest && source.closest("#drawing-refresh, .preview"));
  }

  document.addEventListener("htmx:before:request", function (event) {
    var ctx = event.detail && event.detail.ctx;
    if (!ctx || !counted(ctx) || ctx.millblocksKeys) { return; }
    ctx.millblocksKeys = true;
    if (busy === 0) { busySince = Date.now(); }
    busy += 1;
  });
  document.addEventListener("htmx:finally:request", function (event) {
    var ctx = event.detail && event.detail.ctx;
    if (!ctx || !ctx.millblocksKeys) { return; }
    ctx.millblocksKeys = false;
    busy = Math.max(0, busy - 1);
    if (busy === 0) { drain(); }
  });

  function waiting() {
    // A server that never answers must not keep the keyboard: after 20 s keys go through.
    if (busy > 0 && Date.now() - busySince > 20000) { busy = 0; }
    return busy > 0;
  }

  // One key from the queue, as if pressed now, on whatever has the focus now.
  function replay(key) {
    var target = document.activeElement || document.body;
    var taken = false;
    var event = {
      key: key.key, ctrlKey: key.ctrlKey, altKey: key.altKey, metaKey: key.metaKey,
      shiftKey: key.shiftKey, target: target,
      preventDefault: function () { taken = true; },
    };
    if (shortcut(event)) { return; }
    editorKey(event);
    if (!taken) { browserDefault(target, key); }
  }

  // What the browser does with a key nobody took: a character typed into a prompt, a
  // deletion, a button pressed, Tab to the next prompt.
  function browserDefault(target, key) {
    if (key.ctrlKey || key.metaKey || key.altKey) { return; }
    var text = target.tagName === "INPUT" && !/^(checkbox|radio|button|submit|hidden)$/.test(target.type);
    if (text && key.key.length === 1) {
      var start = target.selectionStart === null ? target.value.length : target.selectionStart;
      var end = target.selectionEnd === null ? start : target.selectionEnd;
      target.setRangeText(key.key, start, end, "end");
      target.dispatchEvent(new Event("input", { bubbles: true }));
    } else if (text && key.key === "Backspace") {
      var from = target.selectionStart, to = target.selectionEnd;
      if (from === to && from > 0) { from -= 1; }
      target.setRangeText("", from, to, "end");
      target.dispatchEvent(new Event("input", { bubbles: true }));
    } else if (key.key === " " && target.type === "checkbox") {
      target.click();
    } else if ((key.key === "Enter" || key.key === " ") && /^(BUTTON|A)$/.test(target.tagName)) {
      target.click();
    } else if (key.key === "Tab") {
      var all = Array.from(document.querySelectorAll("#entry input:not([type=hidden]), #entry select, #entry button, #entry a[href]"))
        .filter(function (el) { return !el.disabled; });
      var at = all.indexOf(target);
      var next = all[at + (key.shiftKey ? -1 : 1)];
      if (next) { next.focus(); }
    }
  }

  // One key at a time, each in its own turn: a key that asks the server (its request starts
  // within the turn) holds the rest until the answer is in.
  function drain() {
    if (waiting() || queue.length === 0) { return; }
    replay(queue.shift());
    setTimeout(drain, 0);
  }

  document.addEventListener("keydown", function (event) {
    if (MODIFIERS.test(event.key) || event.isComposing) { return; }
    if (waiting() || queue.length > 0) {
      event.preventDefault();
      event.stopPropagation();
      queue.push({
        key: event.key, ctrlKey: event.ctrlKey, altKey: event.altKey,
        metaKey: event.metaKey, shiftKey: event.shiftKey,
      });
      return;
    }
    if (shortcut(event)) { return; }
    editorKey(event);
  }, true);

  // After htmx swaps a part of the editor in, put the cursor on the first prompt (or the
  // first choice), and keep the block list in step with the entry panel.
  function focusEntry() {
    // On a menu the menu itself has the focus, so a stray Enter chooses nothing.
    var first = document.querySelector("#entry form.block-form .field [data-field]") ||
      document.querySelector("#entry .choices");
    if (first) { first.focus(); if (first.select) { first.select(); } }
    syncList();
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

  // Typing replaces a prompt's value, as on the control.
  document.addEventListener("focusin", function (event) {
    if (event.target.matches && event.target.matches("input[data-field]") && event.target.select) {
      event.target.select();
    }
  });

  // Only a new entry panel takes the focus: the drawing that follows an edit comes in while
  // the next block is typed, and must not move the cursor back to its first prompt.
  var shownEntry = null;
  function swapped() {
    var entry = document.getElementById("entry");
    if (entry !== shownEntry) {
      shownEntry = entry;
      typeMenu = null;
      focusEntry();
      return;
    }
    syncList();
  }
  document.addEventListener("htmx:after:swap", swapped);

  // A prompt that applies only while others have some values (a pocket's ENTRY, its RAMP
  // ANGLE: the declaration's only_when, app/web/forms.py FieldSpec.shown_when) is shown
  // only then, beside the Enter sequence (data-beside: Tab or the pointer reach it);
  // hidden, it is disabled, so the form sends nothing for it (the block keeps its default).
  function applyShownWhen(form) {
    form.querySelectorAll("[data-shown-when]").forEach(function (field) {
      var shown = field.getAttribute("data-shown-when").split(" ").every(function (pair) {
        var at = pair.indexOf("=");
        var other = form.querySelector('[name="' + pair.slice(0, at) + '"]');
        // "name=a|b": any of the values.
        return other !== null && !other.disabled &&
          pair.slice(at + 1).split("|").indexOf(other.value) >= 0;
      });
      field.hidden = !shown;
      field.querySelectorAll("[data-beside]").forEach(function (el) { el.disabled = !shown; });
    });
  }
  function shownWhenAll() {
    document.querySelectorAll("form.block-form").forEach(applyShownWhen);
  }
  document.addEventListener("htmx:after:swap", shownWhenAll);
  document.addEventListener("DOMContentLoaded", shownWhenAll);
  document.addEventListener("change", function (event) {
    var form = event.target.form;
    if (form && form.matches("form.block-form")) { applyShownWhen(form); }
  });

  // A tool picked from the crib in Data Block 0: its row comes back filled, and the cursor
  // goes to its RPM (offered where none was typed) to be taken or typed over.
  document.addEventListener("htmx:after:swap", function () {
    var row = document.querySelector("tbody.tool-row[data-picked]");
    if (!row) { return; }
    row.removeAttribute("data-picked");
    var rpm = row.querySelector('input[name^="rpm_"]');
    if (rpm) { rpm.focus(); rpm.select(); }
  });

  // The feeds of the program's material follow the tool (app.cnc.crib): a new TOOL # offers
  // its own FEEDR XY / FEEDR Z where the field holds what the form offered, the last tool's
  // offer or nothing; a feed typed is never overwritten.
  document.addEventListener("change", function (event) {
    var input = event.target;
    if (!input.matches || !input.matches("form.block-form [name=tool]")) { return; }
    var form = input.form;
    var offers = JSON.parse(form.getAttribute("data-feed-offers") || "{}");
    var was = form.getAttribute("data-tool-now") || input.defaultValue;
    ["feed_xy", "feed_z"].forEach(function (name) {
      var field = form.querySelector('[name="' + name + '"]');
      if (!field) { return; }
      var before = (offers[was] || {})[name];
      var after = (offers[input.value] || {})[name];
      var offered = field.value === "" || field.value === field.defaultValue || field.value === before;
      if (after !== undefined && offered) { field.value = after; }
    });
    form.setAttribute("data-tool-now", input.value);
  });

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
    shownEntry = document.getElementById("entry");
    focusEntry();
  });
  // Verify in the editor: opening the panel fetches the report per block (the simulation
  // runs on the server) and marks the rows of the blocks it names. A report is about one
  // version of the program (`data-version`): once the page shows another (any edit), its
  // block numbers may name other blocks, so it is put away, the panel says it is out of
  // date, and one key (Alt+R, or its button) runs it again.
  function pageVersion() {
    var version = document.getElementById("version");
    return version ? version.getAttribute("data-version") : null;
  }

  function unmark() {
    document.querySelectorAll(".block-row.has-findings").forEach(function (row) { row.classList.remove("has-findings"); });
  }

  function runVerify(panel) {
    var body = panel.querySelector(".verify-body");
    var asked = pageVersion();
    panel.dataset.state = "running";
    panel.dataset.version = asked || "";
    unmark();
    body.innerHTML = '<p class="hint">Simulating…</p>';
    fetch(panel.dataset.report, { credentials: "same-origin" }).then(function (response) {
      return response.text().then(function (text) { return { ok: response.ok, text: text }; });
    }).then(function (answer) {
      if (panel.dataset.version !== asked || panel.dataset.state !== "running") { return; } // run again meanwhile
      if (!answer.ok) { body.textContent = answer.text; panel.dataset.state = "failed"; return; }
      body.innerHTML = answer.text;
      var result = body.querySelector(".verify-result");
      panel.dataset.version = result ? result.getAttribute("data-version") : "";
      if (panel.dataset.version !== pageVersion()) { outOfDate(panel); return; }
      body.querySelectorAll(".finding[data-block]").forEach(function (finding) {
        var row = document.querySelector('.block-row[data-block="' + finding.dataset.block + '"]');
        if (row) { row.classList.add("has-findings"); }
      });
      panel.dataset.state = "ready";
    }).catch(function () {
      body.textContent = "Verify did not answer; press Alt+R to try again.";
      panel.dataset.state = "failed";
    });
  }

  function outOfDate(panel) {
    var body = panel.querySelector(".verify-body");
    panel.dataset.state = "stale";
    unmark();
    var note = document.createElement("p");
    note.className = "message warning verify-stale";
    note.setAttribute("role", "status");
    note.textContent = "Out of date: the program has changed since this Verify (v" +
      panel.dataset.version + ", now v" + pageVersion() + "); its block numbers may name " +
      "other blocks now. Press Alt+R (or the button above) to run it again.";
    body.replaceChildren(note);
  }

  document.addEventListener("toggle", function (event) {
    var panel = event.target;
    if (!panel.matches || !panel.matches("details.verify-panel") || !panel.open) { return; }
    if (!panel.dataset.state || panel.dataset.state === "failed") { runVerify(panel); }
  }, true);

  document.addEventListener("click", function (event) {
    var button = event.target.closest ? event.target.closest("[data-verify-run]") : null;
    if (!button) { return; }
    var panel = button.closest("details.verify-panel");
    panel.open = true;
    runVerify(panel);
  });

  // After every answer: a report about another version than the page shows is out of date.
  document.addEventListener("htmx:after:swap", function () {
    document.querySelectorAll("details.verify-panel").forEach(function (panel) {
      var state = panel.dataset.state;
      if ((state === "ready" || state === "running") && panel.dataset.version !== pageVersion()) {
        if (state === "running") { panel.dataset.state = "ready"; } // its answer is put away
        outOfDate(panel);
      }
    });
    showShortcuts();
  });

  // The shortcuts are shown: each element with an access key says it in its title, and the
  // keys legend lists them (what the page holds, so it is never out of step).
  function showShortcuts() {
    var named = [];
    document.querySelectorAll("[accesskey]").forEach(function (el) {
      var key = "Alt+" + el.getAttribute("accesskey").toUpperCase();
      var what = (el.getAttribute("data-shortcut") || el.textContent || el.getAttribute("aria-label") ||
        (el.labels && el.labels[0] && el.labels[0].textContent) || "").replace(/\s+/g, " ").trim();
      if (el.title.indexOf(key) < 0) { el.title = (el.title ? el.title + " " : "") + "(" + key + ")"; }
      if (what) { named.push(key + " " + what); }
    });
    document.querySelectorAll(".keys-legend [data-shortcuts]").forEach(function (span) {
      span.textContent = named.length ? " · " + named.join(" · ") : "";
    });
  }
  document.addEventListener("DOMContentLoaded", showShortcuts);
})();
