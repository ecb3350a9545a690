// The block list keeps its place across the editor's answers (issue 20). Every edit and
// save swaps #editor whole (htmx outerHTML), and a new list starts scrolled to its top: the
// row just edited went out of sight. Before a swap, note the first row in view and how far
// below the list's top it sits; after it, scroll the new list so that row sits there again.
// When that row is not in the new list (another page), show the current row instead.
(function () {
  "use strict";

  var kept = null; // { block: "N" or null, offset: px }

  function list() {
    return document.querySelector("#editor .block-list");
  }

  function remember() {
    var ol = list();
    if (!ol) { kept = null; return; }
    var top = ol.getBoundingClientRect().top;
    var rows = ol.querySelectorAll(".block-row[data-block]");
    kept = { block: null, offset: 0 };
    for (var i = 0; i < rows.length; i++) {
      var box = rows[i].getBoundingClientRect();
      if (box.bottom > top + 1) {
        kept = { block: rows[i].dataset.block, offset: box.top - top };
        return;
      }
    }
  }

  function restore() {
    var ol = list();
    if (!ol || !kept) { return; }
    var top = ol.getBoundingClientRect().top;
    var row = kept.block && ol.querySelector('.block-row[data-block="' + kept.block + '"]');
    if (row) {
      ol.scrollTop += row.getBoundingClientRect().top - top - kept.offset;
    } else {
      // Scroll the list only (scrollIntoView would move the whole page too).
      var current = ol.querySelector(".block-row.current");
      if (current) { ol.scrollTop += current.getBoundingClientRect().top - top; }
    }
    kept = null;
  }

  document.addEventListener("htmx:before:swap", remember);
  document.addEventListener("htmx:after:swap", restore);
})();
