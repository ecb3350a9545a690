// The editor's tool path preview: zoom, pan, the pointer's part coordinates, and the link
// between drawing and blocks (click a drawn block to open its row; a chosen row lights up
// its drawing). No inline script anywhere (the Content-Security-Policy forbids it).
//
// A drawing comes from app/cnc/formats/svg.py in one of two ways:
// - inline SVG (most programs): the browser draws it; zoom and pan change its viewBox;
// - a large program's SVG inside an inert <template>: painted here on a canvas. A LOOP's
//   pattern is one <g> in <defs> placed by many <use>s, so each pattern is painted once
//   into a picture at the current scale and the picture is placed at every offset; while
//   dragging, the last frame is moved; zoomed in past a picture's size, patterns are drawn
//   as vectors, only where they are in view.
(function () {
  "use strict";

  var XLINK = "http://www.w3.org/1999/xlink";
  // The canvas's styles, as static/preview.css gives the SVG's (widths in screen pixels).
  var STYLE = {
    rapid: { stroke: "#8a8a8a", width: 1 },
    feed: { stroke: "#0b5fbf", width: 1.6 },
    contour: { stroke: "#111827", width: 1 },
    plunge: { stroke: "#c2410c", width: 1.4 },
    hole: { stroke: "#15803d", width: 1.2 },
    swept: { stroke: "rgba(156, 195, 240, 0.45)", width: 0 },
    stock: { stroke: "#a16207", width: 1, dash: [6, 4] },
    zero: { stroke: "#b91c1c", width: 1.5 },
    grid: { stroke: "#e5e7eb", width: 1 },
  };
  var PROBLEM = "#dc2626";
  var SELECTED = "#f59e0b";
  var PICTURE_MAX = 2048; // a pattern bigger than this on screen is drawn as vectors

  var view = null; // { svg, full, box, canvas, model } — box is the viewBox: x, −part Y, w, h
  var selected = null; // the lit block's number (a string), or null

  function host() { return document.getElementById("preview"); }
  function svgOf() { return document.querySelector("#preview > svg"); }
  // The element the drawing fills: the inline SVG, or the canvas of a large drawing.
  function surface() { var el = host(); return el ? el.querySelector(":scope > svg, :scope > canvas") : null; }
  function decimals() { return host() && host().dataset.units === "mm" ? 3 : 4; }
  function unitName() { return host() && host().dataset.units === "mm" ? "mm" : "in"; }

  // -- both kinds -----------------------------------------------------------------------

  function setupPreview() {
    var el = host();
    if (!el) { view = null; return; }
    var source = el.querySelector("template.source");
    var svg = source ? source.content.querySelector("svg") : svgOf();
    if (!svg) { view = null; return; }
    if (view && view.svg === svg) {
      // The same drawing (another part of the page was swapped, or an edit's changes were
      // applied to it): it keeps its zoom and pan.
      var lit = document.querySelector(".block-row.current[data-block]");
      highlight(lit ? lit.getAttribute("data-block") : null, true);
      apply();
      return;
    }
    var box = svg.getAttribute("viewBox").split(/\s+/).map(Number);
    view = { svg: svg, full: box.slice(), box: box.slice(), canvas: null, model: null };
    if (source) {
      view.canvas = new Painter(el, svg);
      view.model = view.canvas.model;
    }
    var current = document.querySelector(".block-row.current[data-block]");
    highlight(current ? current.getAttribute("data-block") : null, true);
    apply();
  }

  function apply() {
    if (!view) { return; }
    if (view.canvas) { view.canvas.render(); return; }
    var svg = svgOf();
    if (!svg) { return; }
    svg.setAttribute("viewBox", view.box.join(" "));
    // Hole numbers keep their size on screen (about 11 px) at any zoom.
    var order = svg.querySelector("g.order");
    if (order) { order.setAttribute("font-size", String(11 * unitsPerPixel())); }
  }

  // Drawing units per screen pixel (the viewBox is fitted inside, centred: "meet").
  function unitsPerPixel() {
    var el = surface();
    var b = view.box;
    return Math.max(b[2] / Math.max(el.clientWidth, 1), b[3] / Math.max(el.clientHeight, 1));
  }

  // Client pixels → drawing coordinates (viewBox space: part X, −part Y).
  function toDrawing(clientX, clientY) {
    var rect = surface().getBoundingClientRect();
    var b = view.box;
    var k = unitsPerPixel();
    return [b[0] + b[2] / 2 + (clientX - rect.left - rect.width / 2) * k,
            b[1] + b[3] / 2 + (clientY - rect.top - rect.height / 2) * k];
  }

  // Part coordinates → client pixels (the tests and the benchmark point with it).
  function toScreen(x, y) {
    var rect = surface().getBoundingClientRect();
    var b = view.box;
    var k = unitsPerPixel();
    return [rect.left + rect.width / 2 + (x - b[0] - b[2] / 2) / k,
            rect.top + rect.height / 2 + (-y - b[1] - b[3] / 2) / k];
  }

  function zoom(factor, cx, cy) {
    if (!view) { return; }
    var b = view.box;
    if (cx === undefined) { cx = b[0] + b[2] / 2; cy = b[1] + b[3] / 2; }
    view.box = [cx - (cx - b[0]) * factor, cy - (cy - b[1]) * factor, b[2] * factor, b[3] * factor];
    if (view.canvas) { view.canvas.settle(); }
    apply();
  }

  // Light up a block's drawing and its row (`quiet`: without painting again yet).
  function highlight(number, quiet) {
    selected = number;
    document.querySelectorAll("#preview g.block.selected, .block-row.selected").forEach(function (el) {
      el.classList.remove("selected");
    });
    if (number !== null) {
      document.querySelectorAll('#preview g.block[data-block="' + number + '"], .block-row[data-block="' + number + '"]')
        .forEach(function (el) { el.classList.add("selected"); });
    }
    if (view && view.canvas && !quiet) { view.canvas.render(); }
  }

  function openBlock(number) {
    highlight(number);
    var link = document.querySelector('.block-row[data-block="' + number + '"] .block-link');
    if (link) { link.click(); }
  }

  // The block under a click: a <g class="block"> clicked in the SVG, else (a pattern
  // placed by <use>, or the canvas) the block drawn nearest the point.
  function blockAt(event) {
    var group = event.target.closest("#preview g.block");
    if (group) { return group.getAttribute("data-block"); }
    if (!view || !event.target.closest("#preview use, #preview canvas")) { return null; }
    if (!view.model) { view.model = new Model(svgOf()); }
    var p = toDrawing(event.clientX, event.clientY);
    return view.model.pick(p[0], -p[1], 5 * unitsPerPixel());
  }

  function showPointer(event) {
    var readout = document.querySelector(".preview .pointer");
    if (!readout || !view) { return; }
    var p = toDrawing(event.clientX, event.clientY);
    // As many decimals as a screen pixel resolves, up to the unit's printing resolution.
    var places = Math.max(0, Math.min(decimals(), Math.ceil(-Math.log10(unitsPerPixel()))));
    readout.textContent = "X " + (p[0] + 0).toFixed(places) + " Y " + (-p[1] + 0).toFixed(places) + " " + unitName();
  }

  document.addEventListener("click", function (event) {
    var button = event.target.closest("[data-zoom]");
    if (button) {
      var how = button.getAttribute("data-zoom");
      if (how === "fit" && view) {
        view.box = view.full.slice();
        if (view.canvas) { view.canvas.settle(); }
        apply();
      } else { zoom(how === "in" ? 0.7 : 1 / 0.7); }
      return;
    }
    if (event.target.closest("#preview")) {
      var number = dragged ? null : blockAt(event);
      if (number !== null) { openBlock(number); }
      return;
    }
    var row = event.target.closest(".block-row[data-block]");
    if (row) { highlight(row.getAttribute("data-block")); }
  });

  document.addEventListener("change", function (event) {
    var el = host();
    if (!el) { return; }
    if (event.target.matches("[data-swept]")) { el.classList.toggle("swept", event.target.checked); }
    else if (event.target.matches("[data-grid]")) { el.classList.toggle("grid", event.target.checked); }
    else { return; }
    if (view && view.canvas) { view.canvas.forget(); view.canvas.render(); }
  });

  document.addEventListener("wheel", function (event) {
    var inside = event.target.closest ? event.target.closest("#preview") : null;
    if (!inside || !view) { return; }
    event.preventDefault();
    var p = toDrawing(event.clientX, event.clientY);
    zoom(event.deltaY < 0 ? 0.85 : 1 / 0.85, p[0], p[1]);
  }, { passive: false });

  var drag = null;
  var dragged = false;
  document.addEventListener("mousedown", function (event) {
    var inside = event.target.closest ? event.target.closest("#preview") : null;
    if (!inside || !view) { return; }
    drag = { x: event.clientX, y: event.clientY, box: view.box.slice(), scale: unitsPerPixel() };
    dragged = false;
  });
  document.addEventListener("mousemove", function (event) {
    if (view && event.target.closest && event.target.closest("#preview")) { showPointer(event); }
    if (!drag) { return; }
    var dx = (event.clientX - drag.x) * drag.scale;
    var dy = (event.clientY - drag.y) * drag.scale;
    if (Math.abs(dx) + Math.abs(dy) > drag.scale * 3) { dragged = true; }
    view.box = [drag.box[0] - dx, drag.box[1] - dy, drag.box[2], drag.box[3]];
    if (view.canvas) { view.canvas.moving(); }
    apply();
  });
  document.addEventListener("mouseup", function () {
    if (drag && dragged && view && view.canvas) { view.canvas.settle(); }
    drag = null;
    setTimeout(function () { dragged = false; }, 0);
  });

  // -- the drawing as data (for the canvas, and to find the block under a click) -------

  // A drawing read from its SVG: shapes (the <defs> groups) and the page's items. An item
  // is { block, problem, marks: [{ kind, path, width }] }, { use, dx, dy }, or
  // { dx, dy, items } (a translated group); coordinates are part coordinates.
  function Model(svg) {
    var self = this;
    this.shapes = {};
    svg.querySelectorAll("defs > g[id]").forEach(function (g) {
      var box = (g.getAttribute("data-box") || "0 0 0 0").split(/\s+/).map(Number);
      self.shapes[g.id] = { box: box, items: readItems(g), blocks: null };
    });
    var page = svg.querySelector("g.page");
    this.items = page ? readItems(page) : [];
    var grid = page ? page.querySelector("g.grid") : null;
    this.grid = grid ? [{ block: null, marks: readMarks(grid, "grid") }] : [];
    this.extras = [];
    ["stock", "zero"].forEach(function (name) {
      var g = page ? page.querySelector("g." + name) : null;
      if (g) { self.extras.push({ block: null, marks: readMarks(g, name) }); }
    });
    this.labels = Array.prototype.map.call(svg.querySelectorAll("g.order text"), function (t) {
      return [Number(t.getAttribute("x")), Number(t.getAttribute("y")), t.textContent];
    });
  }

  function readItems(parent) {
    var items = [];
    Array.prototype.forEach.call(parent.children, function (child) {
      var tag = child.localName;
      if (tag === "g" && child.classList.contains("block")) {
        items.push({
          block: child.getAttribute("data-block"),
          problem: child.classList.contains("problem"),
          marks: readMarks(child, null),
        });
      } else if (tag === "use") {
        var href = child.getAttributeNS(XLINK, "href") || child.getAttribute("xlink:href") || child.getAttribute("href") || "";
        items.push({ use: href.slice(1), dx: Number(child.getAttribute("x") || 0), dy: Number(child.getAttribute("y") || 0) });
      } else if (tag === "g" && child.hasAttribute("transform")) {
        var m = /translate\(([-\d.e]+)[ ,]+([-\d.e]+)\)/.exec(child.getAttribute("transform"));
        items.push({ dx: m ? Number(m[1]) : 0, dy: m ? Number(m[2]) : 0, items: readItems(child) });
      }
    });
    return items;
  }

  // The drawn things of a group as Path2D objects, each with its class (or `kind`).
  function readMarks(group, kind) {
    var marks = [];
    Array.prototype.forEach.call(group.children, function (el) {
      var path = new Path2D();
      var n = function (name) { return Number(el.getAttribute(name) || 0); };
      if (el.localName === "path") { path = new Path2D(el.getAttribute("d")); }
      else if (el.localName === "circle") { path.arc(n("cx"), n("cy"), n("r"), 0, 2 * Math.PI); }
      else if (el.localName === "line") { path.moveTo(n("x1"), n("y1")); path.lineTo(n("x2"), n("y2")); }
      else if (el.localName === "rect") { path.rect(n("x"), n("y"), n("width"), n("height")); }
      else { return; }
      marks.push({ kind: kind || el.getAttribute("class") || "", path: path, width: n("stroke-width") });
    });
    return marks;
  }

  // The blocks a shape draws (to light up only the patterns that hold the chosen block).
  Model.prototype.blocksOf = function (id) {
    var shape = this.shapes[id];
    if (!shape) { return {}; }
    if (!shape.blocks) { shape.blocks = this.blocksIn(shape.items); }
    return shape.blocks;
  };
  Model.prototype.blocksIn = function (items) {
    var found = {};
    for (var k = 0; k < items.length; k++) {
      var item = items[k];
      var sub = item.marks ? null : item.use ? this.blocksOf(item.use) : this.blocksIn(item.items);
      if (item.marks) { found[item.block] = true; }
      for (var b in sub) { found[b] = true; }
    }
    return found;
  };

  // The block drawn within `tolerance` (part units) of part point (x, y), or null: the
  // topmost, as the drawing paints them.
  Model.prototype.pick = function (x, y, tolerance) {
    var probe = document.createElement("canvas").getContext("2d");
    probe.lineWidth = 2 * tolerance;
    return this.pickIn(probe, this.items, x, y, tolerance);
  };
  Model.prototype.pickIn = function (probe, items, x, y, tolerance) {
    for (var k = items.length - 1; k >= 0; k--) {
      var item = items[k];
      var hit = null;
      if (item.marks) {
        for (var m = 0; m < item.marks.length && hit === null; m++) {
          var mark = item.marks[m];
          if (probe.isPointInStroke(mark.path, x, y) || (mark.kind === "hole" && probe.isPointInPath(mark.path, x, y))) {
            hit = item.block;
          }
        }
      } else if (item.use) {
        var shape = this.shapes[item.use];
        var b = shape ? shape.box : null;
        if (b && x >= b[0] + item.dx - tolerance && x <= b[2] + item.dx + tolerance &&
            y >= b[1] + item.dy - tolerance && y <= b[3] + item.dy + tolerance) {
          hit = this.pickIn(probe, shape.items, x - item.dx, y - item.dy, tolerance);
        }
      } else {
        hit = this.pickIn(probe, item.items, x - item.dx, y - item.dy, tolerance);
      }
      if (hit !== null) { return hit; }
    }
    return null;
  };

  // -- the canvas (large drawings) ------------------------------------------------------

  function Painter(el, svg) {
    var self = this;
    this.el = el;
    this.canvas = el.querySelector("canvas");
    this.model = new Model(svg);
    this.pictures = {};
    this.frame = null; // the last whole frame, moved while dragging
    this.fast = false;
    this.settleTimer = null;
    this.size = [0, 0];
    if (window.ResizeObserver) {
      new ResizeObserver(function () {
        if (self.canvas.clientWidth !== self.size[0] || self.canvas.clientHeight !== self.size[1]) {
          self.forget();
          self.render();
        }
      }).observe(this.canvas);
    }
  }

  // The canvas's pixels per drawing unit.
  Painter.prototype.scale = function () {
    return (window.devicePixelRatio || 1) / unitsPerPixel();
  };
  // The canvas pixel of drawing point (0, 0): the view's centre at the canvas's centre.
  Painter.prototype.origin = function () {
    var s = this.scale();
    var b = view.box;
    return [this.canvas.width / 2 - (b[0] + b[2] / 2) * s, this.canvas.height / 2 - (b[1] + b[3] / 2) * s];
  };

  Painter.prototype.forget = function () { this.pictures = {}; this.frame = null; };
  Painter.prototype.moving = function () { this.fast = true; };
  // After a zoom or a drag, draw properly once things stop moving.
  Painter.prototype.settle = function () {
    var self = this;
    this.fast = true;
    clearTimeout(this.settleTimer);
    this.settleTimer = setTimeout(function () { self.fast = false; self.render(); }, 180);
  };

  Painter.prototype.render = function () {
    var canvas = this.canvas;
    var ratio = window.devicePixelRatio || 1;
    this.size = [canvas.clientWidth, canvas.clientHeight];
    var w = Math.max(1, Math.round(canvas.clientWidth * ratio));
    var h = Math.max(1, Math.round(canvas.clientHeight * ratio));
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; this.frame = null; }
    var ctx = canvas.getContext("2d");
    var s = this.scale();
    var o = this.origin();
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, w, h);
    if (this.fast && this.frame && Math.abs(this.frame.s - s) <= 1e-9 * s) {
      // Dragging: move the last frame (what comes into view follows on release).
      ctx.drawImage(this.frame.image, o[0] - this.frame.o[0], o[1] - this.frame.o[1]);
      return;
    }
    var place = { s: s, x: o[0], y: o[1] }; // part (x, y) → canvas (x·s + px, −y·s + py)
    var model = this.model;
    if (this.el.classList.contains("grid")) { this.drawItems(ctx, model.grid, place, null); }
    this.drawItems(ctx, model.extras, place, null);
    this.drawItems(ctx, model.items, place, null);
    if (selected !== null) { this.drawItems(ctx, model.items, place, selected); }
    this.drawLabels(ctx, s, o);
    if (!this.fast) {
      var copy = this.frame ? this.frame.image : document.createElement("canvas");
      copy.width = w; copy.height = h;
      copy.getContext("2d").drawImage(canvas, 0, 0);
      this.frame = { image: copy, s: s, o: o };
    }
    this.el.dataset.state = "drawn";
  };

  // Items placed at `place`; `only` draws just that block's marks, lit.
  Painter.prototype.drawItems = function (ctx, items, place, only) {
    for (var k = 0; k < items.length; k++) {
      var item = items[k];
      if (item.marks) {
        if (only === null || item.block === only) { this.stroke(ctx, item, place, only); }
      } else if (item.use) {
        if (only === null || this.model.blocksOf(item.use)[only]) { this.drawShape(ctx, item, place, only); }
      } else {
        this.drawItems(ctx, item.items, { s: place.s, x: place.x + item.dx * place.s, y: place.y - item.dy * place.s }, only);
      }
    }
  };

  // A placed pattern: its picture when it is small enough for one, else its vectors; only
  // where it is in view.
  Painter.prototype.drawShape = function (ctx, item, place, only) {
    var shape = this.model.shapes[item.use];
    if (!shape) { return; }
    var b = shape.box;
    var s = place.s;
    var left = place.x + (b[0] + item.dx) * s;
    var top = place.y - (b[3] + item.dy) * s;
    var width = (b[2] - b[0]) * s;
    var height = (b[3] - b[1]) * s;
    var pad = 4;
    if (left + width < -pad || top + height < -pad || left > ctx.canvas.width + pad || top > ctx.canvas.height + pad) { return; }
    var moved = { s: s, x: place.x + item.dx * s, y: place.y - item.dy * s };
    if (width > PICTURE_MAX || height > PICTURE_MAX) { this.drawItems(ctx, shape.items, moved, only); return; }
    var key = item.use + "|" + only;
    var picture = this.pictures[key];
    if (!picture || (!this.fast && Math.abs(picture.s - s) > 1e-9 * s)) {
      picture = this.pictures[key] = this.picture(shape, s, only);
    }
    var k = s / picture.s; // while zooming, the last picture is scaled until things settle
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(picture.image, left - pad * k, top - pad * k, picture.image.width * k, picture.image.height * k);
  };

  Painter.prototype.picture = function (shape, s, only) {
    var b = shape.box;
    var pad = 4;
    var image = document.createElement("canvas");
    image.width = Math.max(1, Math.ceil((b[2] - b[0]) * s) + 2 * pad);
    image.height = Math.max(1, Math.ceil((b[3] - b[1]) * s) + 2 * pad);
    this.drawItems(image.getContext("2d"), shape.items, { s: s, x: pad - b[0] * s, y: pad + b[3] * s }, only);
    return { image: image, s: s };
  };

  Painter.prototype.stroke = function (ctx, item, place, only) {
    var s = place.s;
    var px = (window.devicePixelRatio || 1) / s; // one screen pixel in part units
    var swept = this.el.classList.contains("swept");
    ctx.setTransform(s, 0, 0, -s, place.x, place.y);
    for (var k = 0; k < item.marks.length; k++) {
      var mark = item.marks[k];
      var style = STYLE[mark.kind] || STYLE.contour;
      if (mark.kind === "swept") {
        if (!swept || only !== null) { continue; }
        ctx.lineCap = "round";
        ctx.lineJoin = "round";
        ctx.lineWidth = mark.width;
      } else {
        ctx.lineCap = "butt";
        ctx.lineJoin = "miter";
        ctx.lineWidth = (only !== null ? 3 : style.width) * px;
      }
      ctx.setLineDash(style.dash ? style.dash.map(function (d) { return d * px; }) : []);
      ctx.strokeStyle = only !== null ? SELECTED : item.problem ? PROBLEM : style.stroke;
      ctx.stroke(mark.path);
    }
  };

  Painter.prototype.drawLabels = function (ctx, s, o) {
    var labels = this.model.labels;
    if (!labels.length) { return; }
    var ratio = window.devicePixelRatio || 1;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = "#166534";
    ctx.font = Math.round(11 * ratio) + "px system-ui, sans-serif";
    for (var k = 0; k < labels.length; k++) {
      ctx.fillText(labels[k][2], o[0] + labels[k][0] * s, o[1] + labels[k][1] * s);
    }
  };

  // -- an edit's changes to the drawing -------------------------------------------------
  //
  // An edit's reply carries what changed in the drawing (app/web/preview.py `Patch`, in
  // template#drawing-patch) when the edit said which version the page shows (`drawn`): the
  // new <svg> open tag, and per container (<defs>, the page's <g>, the hole numbers' <g>) its
  // new open tag and the stretch of children that changed. Applied to the drawing shown, it
  // is the new version's drawing; a patch from another version than the one shown (or for
  // a drawing painted on a canvas) is not applied: the whole drawing is asked for instead.

  var CONTAINERS = ["defs", "page", "order"];

  function containerName(el) {
    if (el.localName === "defs") { return "defs"; }
    if (el.localName === "g" && el.classList.contains("page")) { return "page"; }
    if (el.localName === "g" && el.classList.contains("order")) { return "order"; }
    return null;
  }

  function containerIn(svg, name) {
    for (var k = 0; k < svg.children.length; k++) {
      if (containerName(svg.children[k]) === name) { return svg.children[k]; }
    }
    return null;
  }

  // `el` takes the attributes of `from`, but those named in `keep` (the view's own).
  function takeAttributes(el, from, keep) {
    Array.prototype.slice.call(el.attributes).forEach(function (a) {
      if (keep.indexOf(a.name) < 0 && !from.hasAttribute(a.name)) { el.removeAttribute(a.name); }
    });
    Array.prototype.forEach.call(from.attributes, function (a) {
      if (keep.indexOf(a.name) < 0 && el.getAttribute(a.name) !== a.value) {
        el.setAttributeNS(a.namespaceURI, a.name, a.value);
      }
    });
  }

  function askForDrawing(url) {
    if (window.htmx && url) {
      // From #drawing-refresh, whose hx-sync makes the last request for the drawing replace
      // one still on its way (templates/editor/_preview.html).
      window.htmx.ajax("GET", url, { source: "#drawing-refresh", target: "#drawing-holder", swap: "innerHTML" });
    }
  }

  // Apply the reply's patch, once; true when the drawing shown changed.
  function applyPatch() {
    var patch = document.getElementById("drawing-patch");
    if (!patch || !patch.hasAttribute("data-to")) { return false; }
    var to = patch.getAttribute("data-to");
    var fresh = patch.content.querySelector("svg");
    patch.removeAttribute("data-to");
    var el = host();
    var svg = svgOf();
    if (!el || !svg || !fresh || el.dataset.version !== patch.getAttribute("data-from")) {
      askForDrawing(patch.getAttribute("data-refresh"));
      return false;
    }
    takeAttributes(svg, fresh, ["viewBox"]);
    CONTAINERS.forEach(function (name, order) {
      var part = containerIn(fresh, name);
      if (!part) { return; }
      var shown = containerIn(svg, name);
      if (part.hasAttribute("data-gone")) {
        if (shown) { shown.remove(); }
        return;
      }
      var at = Number(part.getAttribute("data-at"));
      var drop = Number(part.getAttribute("data-drop"));
      part.removeAttribute("data-at");
      part.removeAttribute("data-drop");
      if (!shown) {
        // A container the drawing did not have: in its place among the others.
        var next = null;
        for (var k = order + 1; k < CONTAINERS.length && !next; k++) { next = containerIn(svg, CONTAINERS[k]); }
        svg.insertBefore(document.importNode(part, true), next);
        return;
      }
      takeAttributes(shown, part, []);
      for (var n = 0; n < drop && shown.children[at]; n++) { shown.children[at].remove(); }
      var items = document.createDocumentFragment();
      Array.prototype.forEach.call(part.childNodes, function (node) { items.appendChild(document.importNode(node, true)); });
      shown.insertBefore(items, shown.children[at] || null);
    });
    el.dataset.version = to;
    if (view && view.svg === svg) {
      // The extent may have changed: a view that showed it all shows the new one all.
      var box = fresh.getAttribute("viewBox").split(/\s+/).map(Number);
      if (view.box.join(" ") === view.full.join(" ")) { view.box = box.slice(); }
      view.full = box;
      view.model = null;
    }
    return true;
  }

  // An edit's reply says which version the page's drawing is (`drawn`), so the reply can
  // carry only what changed in it.
  document.addEventListener("htmx:config:request", function (event) {
    var ctx = event.detail && event.detail.ctx;
    var el = host();
    var source = ctx && ctx.sourceElement;
    if (!el || !el.dataset.version || !source || !source.closest || !source.closest("#entry")) { return; }
    if (!ctx.request || String(ctx.request.method).toUpperCase() !== "POST") { return; }
    var body = ctx.request.body;
    if (body && typeof body.set === "function") { body.set("drawn", el.dataset.version); }
  });

  // A new drawing, or what changed in it, arrives with the page and with htmx swaps (htmx 4
  // names the event htmx:after:swap; the htmx 1/2 name htmx:afterSwap is never sent).
  document.addEventListener("htmx:after:swap", function () { applyPatch(); setupPreview(); });
  document.addEventListener("DOMContentLoaded", setupPreview);
  // For tests and benchmarks: where a part point is on the screen.
  window.millblocksPreview = { toScreen: function (x, y) { return view ? toScreen(x, y) : null; } };
})();
