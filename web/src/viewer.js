// The 3D view of report.html: the reconstructed terrain as a mesh over the report's height grid,
// with layers after recovery, sensed only (before), ground truth heights and error per cell, and
// the robot's path and camera positions. World frame ENU (z up), metres, as everywhere in the
// project. The data is the JSON in <script id="terrain-view-data">; heights and colours are base64
// arrays (see app/html_report.cpp, which writes them).
import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";

function bytes(b64) {
  const s = atob(b64);
  const out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; ++i) out[i] = s.charCodeAt(i);
  return out;
}

// heights: uint16 little-endian, 0 = no height, else lo + (q - 1) * step
function heights(b64, lo, step) {
  const raw = bytes(b64);
  const view = new DataView(raw.buffer);
  const out = new Float32Array(raw.length / 2);
  for (let i = 0; i < out.length; ++i) {
    const q = view.getUint16(2 * i, true);
    out[i] = q === 0 ? NaN : lo + (q - 1) * step;
  }
  return out;
}

// blue - cyan - green - yellow - red over t in [0, 1]
function ramp(t, out, i) {
  const c = Math.min(1, Math.max(0, t)) * 4;
  const k = Math.min(3, Math.floor(c));
  const f = c - k;
  const stops = [[0.1, 0.2, 0.9], [0.0, 0.8, 0.9], [0.1, 0.8, 0.2], [1.0, 0.85, 0.0], [0.9, 0.1, 0.1]];
  for (let j = 0; j < 3; ++j) out[3 * i + j] = stops[k][j] * (1 - f) + stops[k + 1][j] * f;
}

function start() {
  const holder = document.getElementById("terrain-view");
  const status = document.getElementById("terrain-view-status");
  const data = JSON.parse(document.getElementById("terrain-view-data").textContent);
  const n = data.cols * data.rows;
  const layers = {
    after: heights(data.after, data.lo, data.step),
    before: heights(data.before, data.lo, data.step),
    truth: heights(data.truth, data.lo, data.step),
  };
  const rgb = bytes(data.colours);

  // one vertex per grid point with a height after recovery; two triangles per square of four
  const index = new Int32Array(n).fill(-1);
  let count = 0;
  for (let i = 0; i < n; ++i) if (!Number.isNaN(layers.after[i])) index[i] = count++;
  const xy = new Float32Array(2 * count);
  const triangles = [];
  for (let r = 0; r < data.rows; ++r) {
    for (let c = 0; c < data.cols; ++c) {
      const i = r * data.cols + c;
      if (index[i] < 0) continue;
      xy[2 * index[i]] = data.x0 + (c + 0.5) * data.cell;
      xy[2 * index[i] + 1] = data.y0 + (r + 0.5) * data.cell;
      if (r + 1 === data.rows || c + 1 === data.cols) continue;
      const a = index[i], b = index[i + 1], d = index[i + data.cols], e = index[i + data.cols + 1];
      if (a >= 0 && b >= 0 && e >= 0) triangles.push(a, b, e);
      if (a >= 0 && e >= 0 && d >= 0) triangles.push(a, e, d);
    }
  }
  const positions = new Float32Array(3 * count);
  const colours = new Float32Array(3 * count);
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute("position", new THREE.BufferAttribute(positions, 3));
  geometry.setAttribute("color", new THREE.BufferAttribute(colours, 3));
  geometry.setIndex(triangles);
  const mesh = new THREE.Mesh(geometry, new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide }));

  // the truth as a semi-transparent layer over the reconstruction
  const truthPositions = new Float32Array(3 * count);
  const truthGeometry = new THREE.BufferGeometry();
  truthGeometry.setAttribute("position", new THREE.BufferAttribute(truthPositions, 3));
  truthGeometry.setIndex(triangles);
  const truthLayer = new THREE.Mesh(
    truthGeometry,
    new THREE.MeshLambertMaterial({ color: 0x3070ff, transparent: true, opacity: 0.35, side: THREE.DoubleSide, depthWrite: false }),
  );

  // the layer's heights (a vertex with no height in a layer keeps the one after recovery) and colours
  function show(name) {
    const h = layers[name === "error" ? "after" : name];
    const hr = data.hi - data.lo || 1;
    for (let i = 0, v = 0; i < n; ++i) {
      if (index[i] < 0) continue;
      v = index[i];
      const z = Number.isNaN(h[i]) ? layers.after[i] : h[i];
      positions[3 * v] = xy[2 * v];
      positions[3 * v + 1] = xy[2 * v + 1];
      positions[3 * v + 2] = z;
      const t = layers.truth[i];
      truthPositions[3 * v] = xy[2 * v];
      truthPositions[3 * v + 1] = xy[2 * v + 1];
      truthPositions[3 * v + 2] = Number.isNaN(t) ? z : t;
      if (name === "truth") {
        ramp((z - data.lo) / hr, colours, v);
      } else if (name === "error") {
        // after - truth, -10 m (blue) to +10 m (red), grey where the truth is unknown
        if (Number.isNaN(t)) colours.set([0.6, 0.6, 0.6], 3 * v);
        else ramp((layers.after[i] - t + 10) / 20, colours, v);
      } else {
        colours.set([rgb[3 * i] / 255, rgb[3 * i + 1] / 255, rgb[3 * i + 2] / 255], 3 * v);
      }
    }
    geometry.attributes.position.needsUpdate = true;
    geometry.attributes.color.needsUpdate = true;
    geometry.computeVertexNormals();
    truthGeometry.attributes.position.needsUpdate = true;
    truthGeometry.computeVertexNormals();
    geometry.computeBoundingSphere();
  }

  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xf2f4f7);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
  const sun = new THREE.DirectionalLight(0xffffff, 1.4);
  sun.position.set(-0.3, -0.4, 1);
  scene.add(sun);
  scene.add(mesh);
  scene.add(truthLayer);

  // the robot's path (estimated) and the cameras at the report's frames, each a dot and its view direction
  const pathLine = new THREE.Line(
    new THREE.BufferGeometry().setFromPoints(data.path.map((p) => new THREE.Vector3(p[0], p[1], p[2] + 0.3))),
    new THREE.LineBasicMaterial({ color: 0xd01010 }),
  );
  scene.add(pathLine);
  const cameraMarks = new THREE.Group();
  const rays = [];
  for (const c of data.cameras) {
    rays.push(new THREE.Vector3(c[0], c[1], c[2]), new THREE.Vector3(c[0] + 3 * c[3], c[1] + 3 * c[4], c[2] + 3 * c[5]));
  }
  cameraMarks.add(new THREE.LineSegments(new THREE.BufferGeometry().setFromPoints(rays), new THREE.LineBasicMaterial({ color: 0x101010 })));
  cameraMarks.add(new THREE.Points(
    new THREE.BufferGeometry().setFromPoints(rays.filter((_, i) => i % 2 === 0)),
    new THREE.PointsMaterial({ color: 0xff6000, size: 6, sizeAttenuation: false }),
  ));
  scene.add(cameraMarks);

  const width = holder.clientWidth || 960, height = 600;
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(width, height);
  holder.appendChild(renderer.domElement);
  const camera = new THREE.PerspectiveCamera(50, width / height, 0.5, 5000);
  camera.up.set(0, 0, 1);
  // looking at the middle of what was mapped (the mean of its vertices), from the south-west and above
  const reach = Math.max(data.cols, data.rows) * data.cell;
  const centre = new THREE.Vector3(0, 0, 0);
  for (let v = 0; v < count; ++v) centre.x += xy[2 * v] / count, centre.y += xy[2 * v + 1] / count;
  centre.z = data.path.length ? data.path[0][2] : data.lo;
  camera.position.set(centre.x - 0.4 * reach, centre.y - 0.4 * reach, centre.z + 0.3 * reach);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(centre);
  controls.update();

  const draw = () => renderer.render(scene, camera);
  controls.addEventListener("change", draw);

  // the controls: a layer, and what to show over it; the initial state may come from the URL's hash
  // (#layer=before&truth=1&path=0&cameras=0), which the browser test uses
  const params = new URLSearchParams(location.hash.slice(1));
  const form = document.getElementById("terrain-view-controls");
  const pick = (name, fallback) => params.get(name) ?? fallback;
  form.layer.value = ["after", "before", "truth", "error"].includes(pick("layer", "")) ? pick("layer") : "after";
  form.truth.checked = pick("truth", "0") === "1";
  form.path.checked = pick("path", "1") === "1";
  form.cameras.checked = pick("cameras", "1") === "1";
  const apply = () => {
    show(form.layer.value);
    truthLayer.visible = form.truth.checked;
    pathLine.visible = form.path.checked;
    cameraMarks.visible = form.cameras.checked;
    holder.dataset.layer = form.layer.value;
    draw();
  };
  form.addEventListener("change", apply);
  apply();
  holder.dataset.vertices = String(count);
  holder.dataset.triangles = String(triangles.length / 3);
  status.textContent = `${count} vertices, ${triangles.length / 3} triangles drawn. Drag to orbit, right-drag to pan, wheel to zoom.`;
  holder.dataset.ready = "1";
}

try {
  start();
} catch (e) {
  const status = document.getElementById("terrain-view-status");
  if (status) status.textContent = `The 3D view could not start: ${e.message}`;
  throw e;
}
