// The editor's tool path preview: zoom, pan, and the link between drawing and blocks
// (click a drawn block to open its row; a chosen row lights up its drawing).
// No inline script anywhere (the Content-Security-Policy forbids it): everything is here.
(function () {
  "use strict";

  var view = null;

  function svgOf() { return document.querySelector("#preview svg"); }

  function setupPreview() {
    var svg = svgOf();
    if (!svg) { return; }
    var box = svg.getAttribute("viewBox").split(/\s+/).map(Number);
    view = { full: box.slice(), box: box.slice() };
    var current = document.querySelector(".block-row.current[data-block]");
    if (current) { highlight(current.getAttribute("data-block")); }
  }

  function apply() {
    var svg = svgOf();
    if (svg && view) { svg.setAttribute("viewBox", view.box.join(" ")); }
  }

  function zoom(factor, cx, cy) {
    if (!view) { return; }
    var b = view.box;
    if (cx === undefined) { cx = b[0] + b[2] / 2; cy = b[1] + b[3] / 2; }
    view.box = [cx - (cx - b[0]) * factor, cy - (cy - b[1]) * factor, b[2] * factor, b[3] * factor];
    apply();
  }

  function highlight(number) {
    document.querySelectorAll("#preview g.block.selected, .block-row.selected").forEach(function (el) {
      el.classList.remove("selected");
    });
    document.querySelectorAll('#preview g.block[data-block="' + number + '"], .block-row[data-block="' + number + '"]')
      .forEach(function (el) { el.classList.add("selected"); });
  }

  document.addEventListener("click", function (event) {
    var button = event.target.closest("[data-zoom]");
    if (button) {
      var how = button.getAttribute("data-zoom");
      if (how === "fit" && view) { view.box = view.full.slice(); apply(); }
      else { zoom(how === "in" ? 0.7 : 1 / 0.7); }
      return;
    }
    var group = event.target.closest("#preview g.block");
    if (group && !dragged) {
      var number = group.getAttribute("data-block");
      highlight(number);
      var link = document.querySelector('.block-row[data-block="' + number + '"] .block-link');
      if (link) { link.click(); }
      return;
    }
    var row = event.target.closest(".block-row[data-block]");
    if (row) { highlight(row.getAttribute("data-block")); }
  });

  document.addEventListener("change", function (event) {
    if (event.target.matches("[data-swept]")) {
      document.getElementById("preview").classList.toggle("swept", event.target.checked);
    }
    if (event.target.matches("[data-grid]")) {
      document.getElementById("preview").classList.toggle("grid", event.target.checked);
    }
  });

  document.addEventListener("wheel", function (event) {
    var svg = event.target.closest ? event.target.closest("#preview svg") : null;
    if (!svg || !view) { return; }
    event.preventDefault();
    var point = svg.createSVGPoint();
    point.x = event.clientX; point.y = event.clientY;
    var p = point.matrixTransform(svg.getScreenCTM().inverse());
    zoom(event.deltaY < 0 ? 0.85 : 1 / 0.85, p.x, p.y);
  }, { passive: false });

  var drag = null;
  var dragged = false;
  document.addEventListener("mousedown", function (event) {
    var svg = event.target.closest ? event.target.closest("#preview svg") : null;
    if (!svg || !view) { return; }
    drag = { x: event.clientX, y: event.clientY, box: view.box.slice(), scale: view.box[2] / svg.clientWidth };
    dragged = false;
  });
  document.addEventListener("mousemove", function (event) {
    if (!drag) { return; }
    var dx = (event.clientX - drag.x) * drag.scale;
    var dy = (event.clientY - drag.y) * drag.scale;
    if (Math.abs(dx) + Math.abs(dy) > drag.scale * 3) { dragged = true; }
    view.box = [drag.box[0] - dx, drag.box[1] - dy, drag.box[2], drag.box[3]];
    apply();
  });
  document.addEventListener("mouseup", function () {
    drag = null;
    setTimeout(function () { dragged = false; }, 0);
  });

  // A new drawing arrives with the page and with every htmx swap of the editor.
  document.addEventListener("htmx:after:swap", setupPreview);
  document.addEventListener("htmx:afterSwap", setupPreview);
  document.addEventListener("DOMContentLoaded", setupPreview);
})();
