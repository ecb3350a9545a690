// MillBlocks: the finished part in 3D (three.js, vendored). An ES module loaded from 'self';
// no inline script or style anywhere (the Content-Security-Policy forbids both).
//
// The server sends the simulated height map and, per cell, the block that cut it
// (app/web/verify.py `surface`). The part is drawn as one height field (a vertex per cell
// centre) with side walls and a bottom; the replay slider fetches the map simulated up to
// another block and refills the same buffers; the section slider clips along X; clicking the
// part opens the block that cut there.
import * as THREE from "./vendor/three/three.module.js";
import { OrbitControls } from "./vendor/three/OrbitControls.js";

const HEADER = 60;
const TOP_COLOUR = new THREE.Color(0.8, 0.82, 0.85);
const DEEP_COLOUR = new THREE.Color(0.15, 0.33, 0.6);

function parse(buffer) {
  const view = new DataView(buffer);
  const magic = String.fromCharCode(...new Uint8Array(buffer, 0, 4));
  if (magic !== "MBS1") { throw new Error("not a MillBlocks surface"); }
  const nx = view.getUint32(4, true);
  const ny = view.getUint32(8, true);
  const n = nx * ny;
  return {
    nx, ny,
    x0: view.getFloat64(12, true), y0: view.getFloat64(20, true), res: view.getFloat64(28, true),
    top: view.getFloat64(36, true), bottom: view.getFloat64(44, true),
    upto: view.getUint32(52, true), blocks: view.getUint32(56, true),
    heights: new Float32Array(buffer, HEADER, n),
    owners: new Int32Array(buffer, HEADER + 4 * n, n),
  };
}

async function fetchSurface(url, signal) {
  const response = await fetch(url, { credentials: "same-origin", signal });
  if (!response.ok) { throw new Error(await response.text()); }
  return parse(await response.arrayBuffer());
}

// Triangles of the height field, into `index` (room for two per grid square): a square whose
// four corners are at one height is merged with its neighbours of that height into
// rectangles (rows of them, then rows grown downwards while the next row has the same run),
// so flat stock and pocket floors cost two triangles a rectangle, walls and cones one pair a
// square. A rectangle's edge passes through its neighbours' vertices at its own height, so
// the surface has no cracks. The demo pocket: 139 722 triangles become 2 262 (software
// WebGL transforms and sets up each one every frame). Returns the number of indices written.
function triangulate(s, index) {
  const { nx, ny, heights: h } = s;
  let t = 0;
  const quad = (a, b, c, d) => {
    index[t++] = a; index[t++] = b; index[t++] = c;
    index[t++] = a; index[t++] = c; index[t++] = d;
  };
  const w = nx - 1, rows = ny - 1;
  const used = new Uint8Array(w * rows);
  const flat = (i, j) => {
    const a = i * nx + j, z = h[a];
    return h[a + 1] === z && h[a + nx] === z && h[a + nx + 1] === z;
  };
  for (let i = 0; i < rows; i++) {
    for (let j = 0; j < w; j++) {
      if (used[i * w + j]) { continue; }
      const a = i * nx + j;
      if (!flat(i, j)) {
        quad(a, a + 1, a + nx + 1, a + nx);
        continue;
      }
      const z = h[a];
      let run = 1;
      while (j + run < w && !used[i * w + j + run] && h[a + run + 1] === z && flat(i, j + run)) { run++; }
      let down = 1;
      grow: while (i + down < rows) {
        for (let k = 0; k < run; k++) {
          if (used[(i + down) * w + j + k] || !flat(i + down, j + k) || h[(i + down) * nx + j + k] !== z) { break grow; }
        }
        down++;
      }
      for (let r = 0; r < down; r++) { used.fill(1, (i + r) * w + j, (i + r) * w + j + run); }
      quad(a, a + run, a + down * nx + run, a + down * nx);
      j += run - 1;
    }
  }
  return t;
}

// Normals of the height field from its grid (central differences), not from the triangles:
// a big flat rectangle would otherwise outweigh the narrow wall squares at the vertices they
// share and shade the top of every wall as if it were flat.
function fillNormals(s, normals) {
  const { nx, ny, heights: h, res } = s;
  for (let i = 0; i < ny; i++) {
    for (let j = 0; j < nx; j++) {
      const k = i * nx + j;
      const dx = (h[j + 1 < nx ? k + 1 : k] - h[j > 0 ? k - 1 : k]) / res;
      const dy = (h[i + 1 < ny ? k + nx : k] - h[i > 0 ? k - nx : k]) / res;
      const scale = 1 / Math.hypot(dx, dy, 2);
      normals[k * 3] = -dx * scale; normals[k * 3 + 1] = -dy * scale; normals[k * 3 + 2] = 2 * scale;
    }
  }
}

// The border of the height field, walked counter-clockwise seen from above.
function border(s) {
  const { nx, ny } = s;
  const loop = [];
  for (let j = 0; j < nx; j++) { loop.push(j); }
  for (let i = 1; i < ny; i++) { loop.push(i * nx + nx - 1); }
  for (let j = nx - 2; j >= 0; j--) { loop.push((ny - 1) * nx + j); }
  for (let i = ny - 2; i >= 0; i--) { loop.push(i * nx); }
  return loop;
}

// The part as buffers made once for its grid and refilled for each replay.
class PartMesh {
  constructor(s, material, sideMaterial) {
    const { nx, ny } = s;
    this.nx = nx; this.ny = ny;
    this.positions = new Float32Array(nx * ny * 3);
    for (let i = 0; i < ny; i++) {
      for (let j = 0; j < nx; j++) {
        const k = (i * nx + j) * 3;
        this.positions[k] = s.x0 + (j + 0.5) * s.res;
        this.positions[k + 1] = s.y0 + (i + 0.5) * s.res;
      }
    }
    this.normals = new Float32Array(nx * ny * 3);
    this.colours = new Float32Array(nx * ny * 3);
    this.index = new Uint32Array(Math.max(0, (nx - 1) * (ny - 1) * 6));
    this.geometry = new THREE.BufferGeometry();
    this.geometry.setAttribute("position", new THREE.BufferAttribute(this.positions, 3));
    this.geometry.setAttribute("normal", new THREE.BufferAttribute(this.normals, 3));
    this.geometry.setAttribute("color", new THREE.BufferAttribute(this.colours, 3));
    this.geometry.setIndex(new THREE.BufferAttribute(this.index, 1));
    this.top = new THREE.Mesh(this.geometry, material);
    const loop = border(s);
    this.loop = loop;
    this.wallPositions = new Float32Array((loop.length - 1) * 18);
    this.wallGeometry = new THREE.BufferGeometry();
    this.wallGeometry.setAttribute("position", new THREE.BufferAttribute(this.wallPositions, 3));
    this.walls = new THREE.Mesh(this.wallGeometry, sideMaterial);
    const w = (nx - 1) * s.res, h = (ny - 1) * s.res;
    this.floor = new THREE.Mesh(new THREE.PlaneGeometry(w, h), sideMaterial);
    this.floor.position.set(s.x0 + s.res / 2 + w / 2, s.y0 + s.res / 2 + h / 2, s.bottom);
    this.floor.rotation.x = Math.PI; // face down: seen from below
  }

  fill(s) {
    const positions = this.positions, colours = this.colours;
    const span = Math.max(s.top - s.bottom, 1e-9);
    const c = new THREE.Color();
    for (let k = 0; k < s.heights.length; k++) {
      const z = s.heights[k];
      positions[k * 3 + 2] = z;
      const depth = Math.min(1, Math.max(0, (s.top - z) / span));
      c.copy(TOP_COLOUR).lerp(DEEP_COLOUR, Math.sqrt(depth));
      colours[k * 3] = c.r; colours[k * 3 + 1] = c.g; colours[k * 3 + 2] = c.b;
    }
    fillNormals(s, this.normals);
    const count = triangulate(s, this.index);
    this.geometry.setDrawRange(0, count);
    for (const name of ["position", "normal", "color"]) { this.geometry.attributes[name].needsUpdate = true; }
    this.geometry.index.needsUpdate = true;
    this.geometry.computeBoundingSphere();
    this.fillWalls(s);
    return count / 3;
  }

  fillWalls(s) {
    const loop = this.loop, p = this.wallPositions;
    const at = (k) => [s.x0 + ((k % s.nx) + 0.5) * s.res, s.y0 + (Math.floor(k / s.nx) + 0.5) * s.res];
    let t = 0;
    for (let e = 0; e + 1 < loop.length; e++) {
      const [px, py] = at(loop[e]);
      const [qx, qy] = at(loop[e + 1]);
      const ph = s.heights[loop[e]], qh = s.heights[loop[e + 1]];
      for (const v of [[px, py, ph], [px, py, s.bottom], [qx, qy, s.bottom], [px, py, ph], [qx, qy, s.bottom], [qx, qy, qh]]) {
        p[t++] = v[0]; p[t++] = v[1]; p[t++] = v[2];
      }
    }
    this.wallGeometry.attributes.position.needsUpdate = true;
    this.wallGeometry.computeVertexNormals();
    this.wallGeometry.computeBoundingSphere();
  }
}

function start(element) {
  const canvas = element.querySelector("canvas");
  const pick = document.getElementById("pick");
  const replay = document.getElementById("replay");
  const replayLabel = document.getElementById("replay-label");
  const section = document.getElementById("section");
  const titles = {};
  document.querySelectorAll("#block-titles li").forEach((li) => { titles[li.dataset.block] = li.textContent; });
  const units = element.dataset.units;

  let renderer;
  try {
    renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
  } catch (error) {
    element.dataset.state = "no-webgl";
    pick.textContent = "This browser cannot show 3D (WebGL is off); the report and the PNG picture still work.";
    return;
  }
  renderer.localClippingEnabled = true;
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0.9, 0.91, 0.93);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x445566, 1.6));
  const sun = new THREE.DirectionalLight(0xffffff, 1.8);
  scene.add(sun);
  const camera = new THREE.PerspectiveCamera(35, 1, 0.01, 1e5);
  camera.up.set(0, 0, 1);
  const controls = new OrbitControls(camera, canvas);
  const clip = new THREE.Plane(new THREE.Vector3(-1, 0, 0), 1e9);
  const material = new THREE.MeshLambertMaterial({
    vertexColors: true, side: THREE.DoubleSide, clippingPlanes: [clip],
  });
  const sideMaterial = new THREE.MeshLambertMaterial({
    color: 0x9ca3af, side: THREE.DoubleSide, clippingPlanes: [clip],
  });

  let part = null, surface = null;
  let frames = 0, pending = false;

  function draw() {
    pending = false;
    renderer.render(scene, camera);
    frames += 1;
    element.dataset.frames = String(frames);
  }
  function requestDraw() {
    if (!pending) { pending = true; requestAnimationFrame(draw); }
  }
  function resize() {
    const width = canvas.clientWidth, height = canvas.clientHeight;
    renderer.setSize(width, height, false);
    camera.aspect = width / Math.max(height, 1);
    camera.updateProjectionMatrix();
    requestDraw();
  }
  controls.addEventListener("change", requestDraw);
  new ResizeObserver(resize).observe(canvas);

  function frame(s) {
    const cx = s.x0 + (s.nx * s.res) / 2, cy = s.y0 + (s.ny * s.res) / 2, cz = (s.top + s.bottom) / 2;
    const size = Math.max(s.nx * s.res, s.ny * s.res, s.top - s.bottom);
    controls.target.set(cx, cy, cz);
    camera.position.set(cx - 0.55 * size, cy - 1.35 * size, cz + 1.05 * size);
    camera.near = size / 1000; camera.far = size * 100;
    camera.updateProjectionMatrix();
    sun.position.set(cx - 0.8 * size, cy - 1.5 * size, cz + 1.2 * size);
    controls.update();
  }

  function show(s) {
    if (part === null || part.nx !== s.nx || part.ny !== s.ny) {
      if (part) { scene.remove(part.top, part.walls, part.floor); part.geometry.dispose(); part.wallGeometry.dispose(); }
      frame(s);
      part = new PartMesh(s, material, sideMaterial);
      scene.add(part.top, part.walls, part.floor);
    }
    surface = s;
    const triangles = part.fill(s);
    element.dataset.triangles = String(triangles);
    element.dataset.upto = String(s.upto);
    element.dataset.cells = String(s.nx * s.ny);
    element.dataset.state = "ready";
    requestDraw();
  }

  let loading = null;
  function load(upto) {
    if (loading) { loading.abort(); }
    loading = new AbortController();
    element.dataset.state = "loading";
    const url = element.dataset.surface + (upto === null ? "" : "?upto=" + upto);
    fetchSurface(url, loading.signal).then(show).catch((error) => {
      if (error.name === "AbortError") { return; }
      element.dataset.state = "error";
      pick.textContent = "The part could not be simulated: " + error.message;
    });
  }

  let timer = null;
  replay.addEventListener("input", () => {
    replayLabel.textContent = replay.value;
    clearTimeout(timer);
    timer = setTimeout(() => load(Number(replay.value)), 120);
  });
  section.addEventListener("input", () => {
    if (!surface) { return; }
    const f = Number(section.value) / 1000;
    const x = surface.x0 + f * surface.nx * surface.res;
    clip.constant = f >= 1 ? 1e9 : x;
    requestDraw();
  });

  // Which block cut the place under the pointer.
  const raycaster = new THREE.Raycaster();
  const pointer = new THREE.Vector2();
  function blockAt(event) {
    if (!surface || !part) { return null; }
    const rect = canvas.getBoundingClientRect();
    pointer.set(((event.clientX - rect.left) / rect.width) * 2 - 1, -((event.clientY - rect.top) / rect.height) * 2 + 1);
    raycaster.setFromCamera(pointer, camera);
    const hit = raycaster.intersectObject(part.top)[0];
    if (!hit) { return null; }
    const j = Math.min(surface.nx - 1, Math.max(0, Math.round((hit.point.x - surface.x0) / surface.res - 0.5)));
    const i = Math.min(surface.ny - 1, Math.max(0, Math.round((hit.point.y - surface.y0) / surface.res - 0.5)));
    return { point: hit.point, block: surface.owners[i * surface.nx + j] };
  }
  function describe(found) {
    const p = found.point;
    const where = "X " + p.x.toFixed(3) + " Y " + p.y.toFixed(3) + " Z " + p.z.toFixed(3) + " " + units;
    if (!found.block) { return where + ": uncut stock"; }
    return where + ": cut by block " + found.block + " (" + (titles[found.block] || "") + "); click to open it";
  }
  let down = null;
  canvas.addEventListener("pointerdown", (event) => { down = [event.clientX, event.clientY]; });
  canvas.addEventListener("pointermove", (event) => {
    if (event.buttons) { return; }
    const found = blockAt(event);
    if (found) { pick.textContent = describe(found); }
  });
  canvas.addEventListener("pointerup", (event) => {
    if (!down || Math.hypot(event.clientX - down[0], event.clientY - down[1]) > 4) { return; }
    const found = blockAt(event);
    if (found && found.block) {
      element.dataset.opening = String(found.block);
      window.location.assign(element.dataset.edit + "?edit=" + found.block);
    }
  });

  // For bench/simulate.py, which orbits the camera frame by frame and counts the frames.
  element.view = { renderer, scene, camera, controls };
  load(null);
}

const element = document.getElementById("part-view");
if (element) { start(element); }
