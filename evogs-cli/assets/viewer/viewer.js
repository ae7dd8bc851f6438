// evogs view: the page. Reads scene.json (the run's description), static.bin (colours and
// opacities, once) and one frame per time (positions, rotations, scales): from the server's
// `frame?t=T`, or from the precomputed frames a static export lists. Renders with Spark
// on three.js. Protocol and binary layout: docs/viewer.md.
//
// URL parameters: t=TIME (start time), camera=INDEX (start view, in scene.json's camera
// list), play=1 (start playing), ui=0 (canvas only, for screenshots).

import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { PackedSplats, SparkRenderer, SplatMesh, setPackedSplat } from "@sparkjsdev/spark";

const params = new URLSearchParams(window.location.search);
const el = (id) => document.getElementById(id);

// Whether a server answers (log messages go to its terminal); false for a static export.
let live = false;

function report(level, message) {
  if (!live) return;
  fetch("log", { method: "POST", body: `${level}: ${message}` }).catch(() => {});
}

function showError(message) {
  const box = el("error");
  box.textContent = message;
  box.hidden = false;
  document.title = "evogs view: error";
  document.documentElement.dataset.state = "error";
  report("error", message);
}

function clearError() {
  el("error").hidden = true;
}

window.addEventListener("error", (e) => showError(`page error: ${e.message}`));
window.addEventListener("unhandledrejection", (e) => {
  const r = e.reason;
  showError(`page error: ${r && r.message ? r.message : r}`);
});

/** The body of `url`, or an Error carrying the server's own text (a refused time). */
async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) {
    const text = (await r.text()).trim();
    throw new Error(text || `${url}: HTTP ${r.status}`);
  }
  return r.arrayBuffer();
}

/** Checks a binary header (magic, count) and returns { n, t }. */
function header(buf, magic) {
  if (buf.byteLength < 16) throw new Error(`${magic}: truncated`);
  const dv = new DataView(buf);
  const m = String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3));
  if (m !== magic) throw new Error(`not a ${magic} block (${m})`);
  return { n: dv.getUint32(4, true), t: dv.getFloat64(8, true) };
}

const fmt = (t) => (Math.abs(t) < 1e-9 ? "0" : t.toFixed(3));

async function main() {
  const scene = await (await fetch("scene.json")).json();
  live = !scene.frames;
  const n = scene.gaussians;

  // Colours and opacities, once.
  const statics = await fetchBytes("static.bin");
  if (header(statics, "EVGS").n !== n) throw new Error("static.bin: wrong Gaussian count");
  const rgba = new Uint8Array(statics, 16, 4 * n);

  // Renderer, scene, camera, controls.
  const canvas = el("view");
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  const bg = new THREE.Color().setRGB(...scene.background, THREE.SRGBColorSpace);
  const world = new THREE.Scene();
  world.background = bg;
  const camera = new THREE.PerspectiveCamera(50, 1, 0.01, 1000);
  camera.up.set(...scene.up);
  const controls = new OrbitControls(camera, canvas);
  controls.target.set(...scene.center);
  // The rasterizer's conventions: a 0.3 px² low-pass added to every 2D covariance, 3.33σ
  // support, depth (not radial) sort, alphas below 1/255 dropped.
  const spark = new SparkRenderer({
    renderer,
    preBlurAmount: 0.3,
    maxStdDev: 3.33,
    sortRadial: false,
    minAlpha: 1 / 255,
  });
  world.add(spark);
  const packed = new PackedSplats({ maxSplats: Math.max(n, 1) });
  const mesh = new SplatMesh({ packedSplats: packed });
  world.add(mesh);

  let fovX = 0.8;
  let camAspect = 1;
  function resize() {
    const w = window.innerWidth;
    const h = window.innerHeight;
    renderer.setSize(w, h, false);
    camera.aspect = w / h;
    // The dataset camera's whole view fits the window: its horizontal field of view in a
    // narrower window, its vertical one in a wider window.
    const tanX = Math.tan(fovX / 2);
    const tanY = Math.max(tanX / camera.aspect, tanX / camAspect);
    camera.fov = THREE.MathUtils.radToDeg(2 * Math.atan(tanY));
    camera.updateProjectionMatrix();
  }
  window.addEventListener("resize", resize);

  function useCamera(i) {
    const c = scene.cameras[i];
    if (!c) return;
    const m = new THREE.Matrix4().set(...c.c2w.flat());
    m.decompose(camera.position, camera.quaternion, new THREE.Vector3());
    fovX = c.fov_x;
    camAspect = c.width / c.height;
    // Orbit around the point of the view axis nearest the scene's centre.
    const fwd = new THREE.Vector3(0, 0, -1).applyQuaternion(camera.quaternion);
    const centre = new THREE.Vector3(...scene.center);
    let d = centre.clone().sub(camera.position).dot(fwd);
    if (!(d > 1e-3)) d = centre.distanceTo(camera.position) || 1;
    controls.target.copy(camera.position).addScaledVector(fwd, d);
    resize();
    el("camera").value = String(i);
  }

  // Time, frames.
  const [a, b] = scene.train_range;
  const [lo, hi] = scene.slider_range;
  const slider = el("slider");
  slider.min = String(Math.min(lo, hi));
  slider.max = String(Math.max(lo, hi));
  slider.step = String((hi - lo) / 1000 || 0.001);
  const left = ((a - lo) / (hi - lo || 1)) * 100;
  const width = ((b - a) / (hi - lo || 1)) * 100;
  el("trained").style.left = `${left}%`;
  el("trained").style.width = `${width}%`;
  el("lo").textContent = fmt(lo);
  el("hi").textContent = fmt(hi);
  el("range").textContent = `trained on [${fmt(a)}, ${fmt(b)}]`;
  el("motion").textContent = scene.motion;
  el("count").textContent = String(n);
  const sel = el("camera");
  scene.cameras.forEach((c, i) => {
    const o = document.createElement("option");
    o.value = String(i);
    o.textContent = c.time == null ? c.name : `${c.name} (t = ${fmt(c.time)})`;
    sel.appendChild(o);
  });
  sel.addEventListener("change", () => useCamera(Number(sel.value)));

  /**
   * The frame shown for the wanted time `t`, as { t: its time, url }: from a server the
   * frame at `t` itself; in a static export the listed frame nearest `t`, so the page shows
   * and names that frame's time, not the wanted one.
   */
  function frameFor(t) {
    if (live) return { t, url: `frame?t=${encodeURIComponent(t)}` };
    const ts = scene.frames.times;
    if (ts.length === 0) throw new Error("scene.json lists no frames");
    let best = 0;
    for (let i = 1; i < ts.length; i++) if (Math.abs(ts[i] - t) < Math.abs(ts[best] - t)) best = i;
    return { t: ts[best], url: scene.frames.files[best] };
  }

  /** Puts the frame `f` (from `frameFor`), read into `buf`, on screen. */
  function applyFrame(buf, f) {
    const h = header(buf, "EVGF");
    if (h.n !== n) throw new Error(`${f.url}: wrong Gaussian count`);
    // A frame of another time (a stale or mismatched file) must not pass for this one.
    if (h.t !== f.t) throw new Error(`${f.url}: holds the frame at t = ${h.t}, not at t = ${f.t}`);
    const pos = new Float32Array(buf, 16, 3 * n);
    const rot = new Float32Array(buf, 16 + 12 * n, 4 * n);
    const scl = new Float32Array(buf, 16 + 28 * n, 3 * n);
    const arr = packed.ensureSplats(n);
    for (let i = 0; i < n; i++) {
      const p = 3 * i;
      const q = 4 * i;
      setPackedSplat(
        arr, i,
        pos[p], pos[p + 1], pos[p + 2],
        scl[p], scl[p + 1], scl[p + 2],
        rot[q], rot[q + 1], rot[q + 2], rot[q + 3],
        rgba[q + 3] / 255,
        rgba[q] / 255, rgba[q + 1] / 255, rgba[q + 2] / 255,
      );
    }
    packed.numSplats = n;
    packed.needsUpdate = true;
    mesh.numSplats = n;
    mesh.updateVersion();
  }

  let wanted = null; // the time asked for last (slider, go to, play)
  let shown = null; // the time of the frame on screen (in an export, the nearest listed one)
  let loading = false;
  let settle = 0; // frames rendered since the last update
  let readyReported = false;

  function showTime(t) {
    el("time").textContent = fmt(t);
    const r = el("regime");
    if (t < Math.min(a, b)) {
      r.textContent = "backward rollout";
      r.className = "outside";
    } else if (t > Math.max(a, b)) {
      r.textContent = "forward rollout";
      r.className = "outside";
    } else {
      r.textContent = "in training range";
      r.className = "";
    }
  }

  function request(t) {
    wanted = t;
    showTime(frameFor(t).t);
    if (document.activeElement !== slider) slider.value = String(t);
    pump();
  }

  async function pump() {
    if (loading || wanted === null) return;
    const f = frameFor(wanted);
    if (f.t === shown) return;
    loading = true;
    try {
      applyFrame(await fetchBytes(f.url), f);
      shown = f.t;
      settle = 0;
      clearError();
      el("status").textContent = `${live ? "frame" : "precomputed frame"} at t = ${fmt(f.t)}`;
    } catch (e) {
      shown = f.t;
      showError(e.message);
    } finally {
      loading = false;
    }
    if (frameFor(wanted).t !== shown) pump();
  }

  slider.addEventListener("input", () => request(Number(slider.value)));
  el("goto").addEventListener("change", () => {
    const v = Number(el("goto").value);
    if (Number.isFinite(v)) request(v);
  });
  let playing = params.get("play") === "1";
  el("play").textContent = playing ? "pause" : "play";
  el("play").addEventListener("click", () => {
    playing = !playing;
    el("play").textContent = playing ? "pause" : "play";
  });

  if (params.get("ui") === "0") document.body.classList.add("bare");
  const startCam = Number(params.get("camera") ?? scene.start_camera);
  useCamera(Number.isInteger(startCam) && scene.cameras[startCam] ? startCam : scene.start_camera);
  const t0 = params.has("t") ? Number(params.get("t")) : (scene.cameras[startCam]?.time ?? a);
  request(Number.isFinite(t0) ? t0 : a);

  // 1× plays the training range in 5 seconds.
  const span = Math.abs(b - a) || 1;
  let last = performance.now();
  renderer.setAnimationLoop((now) => {
    const dt = Math.min(0.25, (now - last) / 1000);
    last = now;
    // Time runs on while a frame is computed; the page then asks for the latest time.
    if (playing) {
      let t = (wanted ?? a) + (Number(el("speed").value) * span * dt) / 5;
      if (t > Math.max(lo, hi)) t = Math.min(lo, hi);
      request(t);
    }
    renderer.render(world, camera);
    settle += 1;
    // Ready once the frame asked for is on screen and Spark's sort has caught up.
    if (!readyReported && shown !== null && !loading && settle > 10 && !spark.sorting && document.documentElement.dataset.state !== "error") {
      readyReported = true;
      document.title = `evogs view: ready t=${fmt(shown)}`;
      document.documentElement.dataset.state = "ready";
      report("ready", `t=${shown} camera=${el("camera").value}`);
    }
  });
}

main().catch((e) => showError(e.message || String(e)));
