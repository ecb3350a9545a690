// The block list keeps its place (issues 20 and 32): the one thing that scrolls it.
//
// An edit's reply swaps the rows it changed, or the whole list (#blocks) when blocks moved,
// came or went; a new list starts scrolled to its top, and the row just edited would go out
// of sight. Before a swap, note the first row in view and how far below the list's top it
// sits; after it, scroll the list so that row sits there again. The block the list was
// asked to show (`data-focus` of a new #blocks: the block edited, moved, or where blocks
// are inserted) is then brought wholly into sight, scrolling no more than that takes; when
// the noted row is not in the list (another page), the list is scrolled to show that block
// in its middle, as when the page opens. Only the list scrolls, never the page.
(function () {
  "use strict";

  var kept = null; // { block: "N" or null, offset: px, blocks: the #blocks element }

  function list() {
    return document.querySelector("#editor .block-list");
  }

  function remember() {
    var ol = list();
    if (!ol) { kept = null; return; }
    var top = ol.getBoundingClientRect().top;
    var rows = ol.querySelectorAll(".block-row[data-block]");
    kept = { block: null, offset: 0, blocks: document.getElementById("blocks") };
    for (var i = 0; i < rows.length; i++) {
      var box = rows[i].getBoundingClientRect();
      if (box.bottom > top + 1) {
        kept.block = rows[i].dataset.block;
        kept.offset = box.top - top;
        return;
      }
    }
  }

  // Scroll `ol` so that `row` is wholly in sight: `middle` puts it in the middle, else the
  // list moves only as far as it must.
  function bringIntoSight(ol, row, middle) {
    var top = row.getBoundingClientRect().top - ol.getBoundingClientRect().top + ol.scrollTop;
    var bottom = top + row.offsetHeight;
    if (top >= ol.scrollTop && bottom <= ol.scrollTop + ol.clientHeight) { return; }
    if (middle) {
      ol.scrollTop = Math.max(0, top - (ol.clientHeight - row.offsetHeight) / 2);
    } else if (top < ol.scrollTop) {
      ol.scrollTop = top;
    } else {
      ol.scrollTop = bottom - ol.clientHeight;
    }
  }

  // The row of the block the list was asked to show, when the list is new.
  function focusRow(ol, fresh) {
    var blocks = document.getElementById("blocks");
    if (!fresh || !blocks) { return null; }
    return ol.querySelector('.block-row[data-block="' + blocks.getAttribute("data-focus") + '"]');
  }

  function restore() {
    var ol = list();
    if (!ol) { kept = null; return; }
    var fresh = !kept || kept.blocks !== document.getElementById("blocks");
    var row = kept && kept.block && ol.querySelector('.block-row[data-block="' + kept.block + '"]');
    if (row) {
      var top = ol.getBoundingClientRect().top;
      ol.scrollTop += row.getBoundingClientRect().top - top - kept.offset;
    }
    var focus = focusRow(ol, fresh) || (row ? null : ol.querySelector(".block-row.current"));
    if (focus) { bringIntoSight(ol, focus, !row); }
    kept = null;
  }

  document.addEventListener("htmx:before:swap", remember);
  document.addEventListener("htmx:after:swap", restore);
  document.addEventListener("DOMContentLoaded", function () { kept = null; restore(); });
})();
