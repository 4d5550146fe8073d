// The 3D viewer: one canvas, one camera with orbit controls, two scenes
// (before, after). Side by side draws each scene in half of the canvas;
// the slider layout draws both over the whole canvas, each clipped to its
// side of the slider. Either way the camera is shared, so the views stay
// linked. Frames are drawn on demand (when the camera or the content
// changes), never in a busy loop.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { qualityGeometry } from './quality.js';

const WIRE_COLOUR = 0x1a2a3a;

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
    this.controls.addEventListener('change', () => this.draw());
    new ResizeObserver(() => this.resize()).observe(canvas);
    this.resize();
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.canvas;
    if (w === 0 || h === 0) return;
    this.renderer.setSize(w, h, false);
    this.draw();
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
    }
    this.draw();
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
        o.add(overlay);
        this.overlays[side].push(overlay);
      }
    }
  }

  /** Draws one frame. */
  draw() {
    const r = this.renderer;
    const size = r.getSize(new THREE.Vector2());
    const [w, h] = [size.x, size.y];
    if (w === 0 || h === 0) return;
    r.setScissorTest(true);
    if (this.layout === 'side') {
      this.camera.aspect = w / 2 / h;
      this.camera.updateProjectionMatrix();
      this.view(this.scenes.before, 0, 0, Math.floor(w / 2), h, 0, w / 2);
      this.view(this.scenes.after, Math.floor(w / 2), 0, w - Math.floor(w / 2), h, w / 2, w / 2);
    } else {
      this.camera.aspect = w / h;
      this.camera.updateProjectionMatrix();
      const cut = Math.round(w * this.split);
      this.view(this.scenes.before, 0, 0, cut, h, 0, w);
      this.view(this.scenes.after, cut, 0, w - cut, h, 0, w);
    }
    r.setScissorTest(false);
  }

  /** Draws `scene` into the scissor rectangle (x, y, w, h) of a viewport at vx, width vw. */
  view(scene, x, y, w, h, vx, vw) {
    if (w <= 0) return;
    this.renderer.setViewport(vx, 0, vw, this.renderer.getSize(new THREE.Vector2()).y);
    this.renderer.setScissor(x, y, w, h);
    scene.add(this.camera);
    this.renderer.render(scene, this.camera);
  }

  /**
   * Frame time: draws `frames` frames while orbiting the camera and waits
   * for each to finish (a one-pixel read back). Returns milliseconds per
   * frame (median and max).
   */
  timeFrames(frames = 30) {
    const gl = this.renderer.getContext();
    const pixel = new Uint8Array(4);
    const times = [];
    for (let i = 0; i < frames; i++) {
      const t0 = performance.now();
      this.camera.position.applyAxisAngle(new THREE.Vector3(0, 1, 0), (2 * Math.PI) / frames);
      this.camera.lookAt(this.controls.target);
      this.draw();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
      times.push(performance.now() - t0);
    }
    times.sort((a, b) => a - b);
    return { median: times[Math.floor(frames / 2)], max: times[frames - 1], frames };
  }
}
