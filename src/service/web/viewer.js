// The 3D viewer: one canvas, one camera with orbit controls, two scenes
// (before, after). Side by side draws each scene in half of the canvas;
// the slider layout draws both over the whole canvas, each clipped to its
// side of the slider. Either way the camera is shared, so the views stay
// linked. Frames are drawn on demand (when the camera or the content
// changes), never in a busy loop.
//
// A side with more than `PROXY_ABOVE` triangles is drawn through a coarse
// stand-in (lod.js) while the camera moves. Once it has rested for
// `SETTLE_MS`, the full meshes are drawn into an off-screen target a
// slice of triangles per animation frame, and the finished image replaces
// the stand-in's at once; moving again abandons the unfinished image. So
// no single frame holds the page for long, whatever the mesh size.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { qualityGeometry } from './quality.js';
import { PROXY_ABOVE, proxyOf, triangleTotal } from './lod.js';

const WIRE_COLOUR = 0x1a2a3a;
/** Quiet time after the last camera move before the full meshes are drawn. */
const SETTLE_MS = 150;
/**
 * Work of one refining frame, in triangles weighted by their cost: a
 * triangle of a quality colouring (not indexed) counts 3, a wireframe
 * overlay adds 5.
 */
const SLICE_WORK = 300_000;

function makeScene() {
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xf4f6f8);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
  return scene;
}

export class Viewer {
  constructor(canvas) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
    this.light = new THREE.DirectionalLight(0xffffff, 1.8);
    this.light.position.set(1, 2, 3);
    this.camera.add(this.light);
    this.scenes = { before: makeScene(), after: makeScene() };
    this.objects = { before: null, after: null };
    this.overlays = { before: [], after: [] };
    this.layout = 'side';
    this.display = 'shaded';
    this.colour = 'material';
    this.split = 0.5;
    this.target = { before: 1, after: 1 };
    this.counts = null;
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.addEventListener('change', () => this.moved());
    this.refining = 0; // bumped to abandon a refinement under way
    this.settle = null;
    this.target2 = null; // the off-screen target of refinements
    this.present = makePresenter();
    new ResizeObserver(() => this.resize()).observe(canvas);
    this.resize();
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.canvas;
    if (w === 0 || h === 0) return;
    this.renderer.setSize(w, h, false);
    this.redraw();
  }

  /** Shows `object` as the 'before' or 'after' side (null clears it). */
  set(side, object, target = 1) {
    const scene = this.scenes[side];
    if (this.objects[side]) scene.remove(this.objects[side].root);
    this.objects[side] = null;
    this.target[side] = target;
    if (object) {
      const root = new THREE.Group();
      root.add(object);
      this.objects[side] = { root, original: object, quality: null };
      scene.add(root);
      if (side === 'after' || !this.objects.after) this.frame(object);
    }
    this.apply();
  }

  /** Sets the target length L that side's edge-length colours divide by. */
  setTarget(side, target) {
    const entry = this.objects[side];
    this.target[side] = target;
    if (entry?.quality) {
      entry.quality.mesh.removeFromParent();
      entry.quality.mesh.geometry.dispose();
      entry.quality = null;
    }
    this.apply();
  }

  /** Points the camera at `object` from a three-quarter view. */
  frame(object) {
    const box = new THREE.Box3().setFromObject(object);
    if (box.isEmpty()) return;
    const centre = box.getCenter(new THREE.Vector3());
    const radius = box.getSize(new THREE.Vector3()).length() / 2 || 1;
    this.camera.near = radius / 100;
    this.camera.far = radius * 100;
    this.camera.position.copy(centre).add(new THREE.Vector3(-0.9, 0.6, -1.5).normalize().multiplyScalar(radius * 2.6));
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(centre);
    this.controls.update();
  }

  setMode({ layout, display, colour, split }) {
    if (layout) this.layout = layout;
    if (display) this.display = display;
    if (colour) this.colour = colour;
    if (split !== undefined) this.split = split;
    this.apply();
  }

  /** Rebuilds what each scene shows from the current modes. */
  apply() {
    this.counts = null;
    for (const side of ['before', 'after']) {
      const entry = this.objects[side];
      this.overlays[side].forEach((o) => o.removeFromParent());
      this.overlays[side] = [];
      if (!entry) continue;
      let shown = entry.original;
      entry.original.visible = this.colour === 'material';
      if (entry.quality) entry.quality.mesh.visible = false;
      if (this.colour !== 'material') {
        if (!entry.quality || entry.quality.mode !== this.colour) {
          if (entry.quality) {
            entry.quality.mesh.removeFromParent();
            entry.quality.mesh.geometry.dispose();
          }
          const { geometry, counts } = qualityGeometry(entry.original, this.colour, this.target[side]);
          const material = new THREE.MeshStandardMaterial({
            vertexColors: true,
            flatShading: true,
            roughness: 0.8,
            side: THREE.DoubleSide,
          });
          const mesh = new THREE.Mesh(geometry, material);
          entry.root.add(mesh);
          entry.quality = { mode: this.colour, mesh, counts };
        }
        entry.quality.mesh.visible = true;
        shown = entry.quality.mesh;
        if (side === 'after') this.counts = entry.quality.counts;
      }
      this.styleSurfaces(side, shown);
      entry.shown = shown;
      entry.triangles = triangleTotal(shown);
    }
    this.redraw();
  }

  /** Draws the current content: at once, or for a heavy mesh stand-in first, then in slices. */
  redraw() {
    if (!this.heavy()) return this.draw();
    this.quickFrame();
    this.refine();
  }

  /** Whether a side has more triangles than a moving view should draw. */
  heavy() {
    return ['before', 'after'].some((s) => this.objects[s]?.triangles > PROXY_ABOVE);
  }

  /** The camera moved: a quick frame now, the full one once it rests. */
  moved() {
    if (!this.heavy()) return this.draw();
    this.quickFrame();
    clearTimeout(this.settle);
    this.settle = setTimeout(() => this.refine(), SETTLE_MS);
  }

  /**
   * A frame of the stand-ins, drawn off-screen and shown: the canvas is
   * multisampled, which a software renderer pays for per pixel, and a
   * moving view does not need it.
   */
  quickFrame() {
    this.refining++;
    const target = this.offscreen();
    this.withProxies(() => this.draw(target));
    this.present(this.renderer, target);
    this.canvas.dataset.frame = 'quick';
  }

  /** The off-screen target, at the canvas's size in device pixels. */
  offscreen() {
    const size = this.renderer.getDrawingBufferSize(new THREE.Vector2());
    if (!this.target2 || this.target2.width !== size.x || this.target2.height !== size.y) {
      this.target2?.dispose();
      // Not multisampled: three.js discards a multisampled target's samples
      // after each render, and slices must add up.
      this.target2 = new THREE.WebGLRenderTarget(size.x, size.y, { colorSpace: THREE.SRGBColorSpace });
    }
    return this.target2;
  }

  /** Runs `fn` with each heavy side's stand-in shown in place of its meshes. */
  withProxies(fn) {
    const swapped = [];
    for (const side of ['before', 'after']) {
      const entry = this.objects[side];
      if (!(entry?.triangles > PROXY_ABOVE)) continue;
      entry.proxies ??= new Map();
      const key = entry.shown;
      if (!entry.proxies.has(key)) {
        const proxy = proxyOf(key);
        proxy.visible = false;
        entry.root.add(proxy);
        entry.proxies.set(key, proxy);
      }
      const proxy = entry.proxies.get(key);
      key.visible = false;
      proxy.visible = true;
      swapped.push([key, proxy]);
    }
    try {
      fn();
    } finally {
      for (const [shown, proxy] of swapped) {
        shown.visible = true;
        proxy.visible = false;
      }
    }
  }

  /**
   * Slices of the full frame: for each, a function that draws it into the
   * off-screen target. Each mesh draws the same fraction of its triangles
   * per slice, so every slice costs about `SLICE_WORK`.
   */
  slices() {
    const target = this.offscreen();
    const weight = (this.colour === 'material' ? 1 : 3) + (this.display === 'shaded' ? 0 : 5);
    const work = ['before', 'after'].reduce((n, s) => n + (this.objects[s]?.triangles ?? 0), 0) * weight;
    const count = Math.max(1, Math.ceil(work / SLICE_WORK));
    const meshes = [];
    for (const side of ['before', 'after']) this.objects[side]?.shown.traverse((o) => o.isMesh && !o.userData.wire && meshes.push(o));
    return Array.from({ length: count }, (_, k) => () => {
      for (const m of meshes) {
        const g = m.geometry;
        const n = g.index ? g.index.count : g.getAttribute('position').count;
        const per = 3 * Math.ceil(n / 3 / count);
        g.setDrawRange(k * per, per);
      }
      try {
        this.draw(target, k === 0);
      } finally {
        for (const m of meshes) m.geometry.setDrawRange(0, Infinity);
      }
    });
  }

  /** Draws the full frame slice by slice, one per animation frame, then shows it. */
  refine() {
    const token = ++this.refining;
    this.canvas.dataset.frame = 'refining';
    const slices = this.slices();
    let k = 0;
    const step = () => {
      if (token !== this.refining) return;
      slices[k++]();
      if (k < slices.length) requestAnimationFrame(step);
      else {
        this.present(this.renderer, this.target2);
        this.canvas.dataset.frame = 'full';
      }
    };
    requestAnimationFrame(step);
  }

  /** Shaded, wireframe, or both: hides the surface or adds wire overlays. */
  styleSurfaces(side, shown) {
    const wire = this.display !== 'shaded';
    const surface = this.display !== 'wireframe';
    const meshes = [];
    shown.traverse((o) => o.isMesh && meshes.push(o));
    for (const o of meshes) {
      for (const m of [o.material].flat()) {
        m.colorWrite = surface;
        m.depthWrite = surface;
        m.polygonOffset = wire;
        m.polygonOffsetFactor = 1;
        m.polygonOffsetUnits = 1;
        m.needsUpdate = true;
      }
      if (wire) {
        const overlay = new THREE.Mesh(
          o.geometry,
          new THREE.MeshBasicMaterial({ color: WIRE_COLOUR, wireframe: true }),
        );
        overlay.userData.wire = true;
        o.add(overlay);
        this.overlays[side].push(overlay);
      }
    }
  }

  /**
   * Draws one frame: on the canvas (which abandons any refinement under
   * way), or into the off-screen `target`, cleared first if `clear`.
   */
  draw(target = null, clear = true) {
    const r = this.renderer;
    const size = r.getSize(new THREE.Vector2());
    const [w, h] = [size.x, size.y];
    if (w === 0 || h === 0) return;
    if (!target) {
      this.refining++;
      this.canvas.dataset.frame = 'full';
    }
    r.setRenderTarget(target);
    r.autoClear = clear;
    r.setScissorTest(true);
    if (target) target.scissorTest = true;
    if (this.layout === 'side') {
      this.camera.aspect = w / 2 / h;
      this.camera.updateProjectionMatrix();
      this.view(target, this.scenes.before, 0, 0, Math.floor(w / 2), h, 0, w / 2);
      this.view(target, this.scenes.after, Math.floor(w / 2), 0, w - Math.floor(w / 2), h, w / 2, w / 2);
    } else {
      this.camera.aspect = w / h;
      this.camera.updateProjectionMatrix();
      const cut = Math.round(w * this.split);
      this.view(target, this.scenes.before, 0, 0, cut, h, 0, w);
      this.view(target, this.scenes.after, cut, 0, w - cut, h, 0, w);
    }
    r.setScissorTest(false);
    r.autoClear = true;
    r.setRenderTarget(null);
  }

  /**
   * Draws `scene` into the scissor rectangle (x, y, w, h) of a viewport at
   * vx, width vw, in CSS pixels; an off-screen target counts device pixels.
   */
  view(target, scene, x, y, w, h, vx, vw) {
    if (w <= 0) return;
    const full = this.renderer.getSize(new THREE.Vector2()).y;
    if (target) {
      const px = this.renderer.getPixelRatio();
      target.viewport.set(vx * px, 0, vw * px, full * px);
      target.scissor.set(x * px, y * px, w * px, h * px);
      this.renderer.setRenderTarget(target); // three.js reads them on binding
    } else {
      this.renderer.setViewport(vx, 0, vw, full);
      this.renderer.setScissor(x, y, w, h);
    }
    scene.add(this.camera);
    // A colour background clears whatever autoClear says: lift it for the
    // slices that add to a frame.
    const background = scene.background;
    if (!this.renderer.autoClear) scene.background = null;
    this.renderer.render(scene, this.camera);
    scene.background = background;
  }

  /**
   * Frame times, each waited for with a one-pixel read back, in ms: one
   * full frame drawn directly; `frames` frames while orbiting the camera
   * (`moving`, through the stand-ins where a side is heavy); and the slices
   * of the refinement that follows, which ends with the full image shown.
   */
  timeFrames(frames = 30) {
    const gl = this.renderer.getContext();
    const pixel = new Uint8Array(4);
    const timed = (fn, read = () => gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel)) => {
      const t0 = performance.now();
      fn();
      read();
      return performance.now() - t0;
    };
    const summary = (times) => {
      const sorted = [...times].sort((a, b) => a - b);
      const total = times.reduce((a, b) => a + b, 0);
      return { count: times.length, median: sorted[Math.floor(times.length / 2)], max: sorted[times.length - 1], total };
    };
    const full_frame_ms = timed(() => this.draw());
    const heavy = this.heavy();
    const moving = [];
    for (let i = 0; i < frames; i++) {
      moving.push(
        timed(() => {
          this.camera.position.applyAxisAngle(new THREE.Vector3(0, 1, 0), (2 * Math.PI) / frames);
          this.camera.lookAt(this.controls.target);
          if (heavy) this.quickFrame();
          else this.draw();
        }),
      );
    }
    const readTarget = () => this.renderer.readRenderTargetPixels(this.target2, 0, 0, 1, 1, pixel);
    const slices = heavy ? this.slices().map((slice) => timed(slice, readTarget)) : [];
    const present_ms = heavy ? timed(() => this.present(this.renderer, this.target2)) : 0;
    this.canvas.dataset.frame = 'full';
    const proxy_triangles = {};
    for (const side of ['before', 'after']) {
      const proxy = this.objects[side]?.proxies?.get(this.objects[side].shown);
      proxy_triangles[side] = proxy ? proxy.geometry.index.count / 3 : 0;
    }
    return { full_frame_ms, moving: summary(moving), slices: summary(slices), present_ms, proxy_triangles };
  }
}

/** A function that draws an off-screen target's colour over the whole canvas. */
function makePresenter() {
  const material = new THREE.MeshBasicMaterial({ toneMapped: false, depthTest: false, depthWrite: false });
  const scene = new THREE.Scene();
  scene.add(new THREE.Mesh(new THREE.PlaneGeometry(2, 2), material));
  const camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
  camera.position.z = 0.5;
  return (renderer, target) => {
    if (material.map !== target.texture) {
      material.map = target.texture;
      material.needsUpdate = true;
    }
    const size = renderer.getSize(new THREE.Vector2());
    renderer.setRenderTarget(null);
    renderer.setScissorTest(false);
    renderer.setViewport(0, 0, size.x, size.y);
    renderer.render(scene, camera);
  };
}
