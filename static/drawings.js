// The choosing page (issue 22): clicks on the drawing fill the form's order and start
// fields; the form itself is the whole state (it works typed, without this script).
(function () {
  "use strict";

  function choices() { return document.getElementById("choices"); }

  function field(name) {
    var form = choices();
    return form ? form.querySelector('[name="' + name + '"]') : null;
  }

  function orders() {
    var form = choices();
    return form ? Array.prototype.slice.call(form.querySelectorAll('input[name$="_order"]')) : [];
  }

  function nextOrder() {
    var most = 0;
    orders().forEach(function (input) {
      var n = parseInt(input.value, 10);
      if (n > most) { most = n; }
    });
    return most + 1;
  }

  // Show on the drawing what the form says: chosen contours and holes (with their order),
  // and where each chosen contour starts.
  function mark() {
    document.querySelectorAll("#dxf-view g.contour").forEach(function (group) {
      var k = group.getAttribute("data-contour");
      var order = field("c" + k + "_order");
      var start = field("c" + k + "_start");
      var chosen = order && order.value.trim() !== "";
      group.classList.toggle("chosen", chosen);
      group.querySelectorAll(".segment").forEach(function (segment) {
        var first = start && String(parseInt(segment.getAttribute("data-segment"), 10) + 1) === start.value;
        segment.classList.toggle("start", Boolean(chosen && first));
      });
    });
    document.querySelectorAll("#dxf-view circle.hole").forEach(function (hole) {
      var order = field("h" + hole.getAttribute("data-hole") + "_order");
      hole.classList.toggle("chosen", Boolean(order && order.value.trim() !== ""));
    });
    document.querySelectorAll(".contour-row, .hole-row").forEach(function (row) {
      var input = row.querySelector('input[name$="_order"]');
      row.classList.toggle("chosen", Boolean(input && input.value.trim() !== ""));
    });
  }

  function refresh() {
    mark();
    var show = document.getElementById("show-blocks");
    if (show) { show.click(); }
  }

  document.addEventListener("click", function (event) {
    var target = event.target;
    if (!target.closest) { return; }
    if (target.closest("[data-clear]")) {
      orders().forEach(function (input) { input.value = ""; });
      refresh();
      return;
    }
    var hole = target.closest("#dxf-view circle.hole");
    if (hole) {
      var holeOrder = field("h" + hole.getAttribute("data-hole") + "_order");
      holeOrder.value = holeOrder.value.trim() ? "" : String(nextOrder());
      refresh();
      return;
    }
    var group = target.closest("#dxf-view g.contour");
    if (!group) { return; }
    var k = group.getAttribute("data-contour");
    var order = field("c" + k + "_order");
    var start = field("c" + k + "_start");
    var segment = target.closest(".segment");
    if (!order.value.trim()) {
      order.value = String(nextOrder());
      if (segment && start && group.classList.contains("closed")) {
        start.value = String(parseInt(segment.getAttribute("data-segment"), 10) + 1);
      }
    } else if (segment && start && group.classList.contains("closed")) {
      var clicked = String(parseInt(segment.getAttribute("data-segment"), 10) + 1);
      if (start.value === clicked) {
        order.value = "";  // a second click where it starts: not chosen any more
      } else {
        start.value = clicked;
      }
    } else {
      order.value = "";
    }
    refresh();
  });

  // A field changed by hand (an order typed, a direction chosen, a depth or the tool's
  // diameter): show its blocks and their tool path.
  document.addEventListener("change", function (event) {
    var inFields = event.target.closest &&
      event.target.closest("#choices .tables, #choices fieldset.cutting");
    if (inFields) { refresh(); }
  });
  // The tool path of the chosen blocks drawn on the drawing itself: the tool centre and the
  // band the tool's diameter sweeps, copied from the blocks' preview (the server draws it
  // with the core's cutter compensation; the drawing and the preview share coordinates:
  // part zero at the drawing's origin, the program's units, Y up through a flip).
  function overlay() {
    var drawing = document.querySelector("#dxf-view svg");
    if (!drawing) { return; }
    var old = drawing.querySelector("g.tool-centre");
    if (old) { old.remove(); }
    var paths = document.querySelectorAll(
      "#result .chosen-preview g.block path.feed, #result .chosen-preview g.block path.swept"
    );
    if (!paths.length) { return; }
    var layer = document.createElementNS("http://www.w3.org/2000/svg", "g");
    layer.setAttribute("class", "tool-centre");
    layer.setAttribute("transform", "scale(1,-1)");
    var title = document.createElementNS("http://www.w3.org/2000/svg", "title");
    title.textContent = "the tool centre and the width the tool sweeps";
    layer.appendChild(title);
    // The bands first, the centre lines over them.
    Array.prototype.slice.call(paths)
      .sort(function (a, b) { return (b.classList.contains("swept") ? 1 : 0) - (a.classList.contains("swept") ? 1 : 0); })
      .forEach(function (path) { layer.appendChild(path.cloneNode(false)); });
    drawing.appendChild(layer);
  }

  // htmx 4 names the event htmx:after:swap (its htmx 1/2 name, htmx:afterSwap, is never sent).
  document.addEventListener("htmx:after:swap", overlay);
  document.addEventListener("DOMContentLoaded", function () { mark(); overlay(); });
})();
