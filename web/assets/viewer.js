// scanrig's 3D viewer: the layers of a page's scene (clouds, meshes, line drawings) in one WebGL
// canvas, drawn by three.js (the global THREE, inlined before this script). Orbit with the left
// button, pan with the right, zoom with the wheel; a click reads the coordinates of the nearest
// point or surface under the cursor.
//
// The scene comes from the page itself (no network, so the page opens from a file:// path): a JSON
// description in <script id="scene"> and binary blocks, gzip in base64, in <script id="block-N">:
// positions as uint16 triples quantised over the scene's bounds, colours as sRGB bytes, triangle and
// segment indices as uint32 (all little-endian). Layers that share a block share its GPU buffer: the
// error-coloured mesh is the mesh's geometry with other colours.
(function () {
  'use strict';

  const status = document.getElementById('viewer-status');
  function fail(e) {
    // Said on the page and on the console, where the browser test looks for it.
    console.error('scanrig viewer:', e);
    if (status) status.textContent = 'The viewer failed: ' + e;
  }

  // A block's bytes: base64 of gzip. fetch decodes data: URLs natively (faster than atob on
  // megabytes) and DecompressionStream inflates without a script library.
  async function blockBytes(id) {
    const el = document.getElementById(id);
    if (!el) throw new Error('missing data block ' + id);
    const packed = await fetch('data:application/octet-stream;base64,' + el.textContent.trim());
    const inflated = packed.body.pipeThrough(new DecompressionStream('gzip'));
    return new Uint8Array(await new Response(inflated).arrayBuffer());
  }

  // sRGB byte → linear: three.js lights and blends in linear light and encodes sRGB on output.
  const toLinear = new Float32Array(256);
  for (let i = 0; i < 256; i++) {
    const c = i / 255;
    toLinear[i] = c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4);
  }

  async function main() {
    const spec = JSON.parse(document.getElementById('scene').textContent);
    const canvas = document.getElementById('viewer-canvas');
    const lo = spec.bounds.min, hi = spec.bounds.max;
    const size = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    const diag = Math.max(Math.hypot(size[0], size[1], size[2]), 1e-6);
    const centre = new THREE.Vector3((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2);

    const attributes = new Map();
    async function attribute(id, kind) {
      const key = id + ':' + kind;
      if (attributes.has(key)) return attributes.get(key);
      const bytes = await blockBytes(id);
      let attr;
      if (kind === 'position') {
        const q = new Uint16Array(bytes.buffer, bytes.byteOffset, bytes.byteLength / 2);
        const f = new Float32Array(q.length);
        for (let i = 0; i < q.length; i++) {
          const k = i % 3;
          f[i] = lo[k] + (q[i] / 65535) * size[k];
        }
        attr = new THREE.BufferAttribute(f, 3);
      } else if (kind === 'colour') {
        const f = new Float32Array(bytes.length);
        for (let i = 0; i < bytes.length; i++) f[i] = toLinear[bytes[i]];
        attr = new THREE.BufferAttribute(f, 3);
      } else {
        attr = new THREE.BufferAttribute(new Uint32Array(bytes.buffer, bytes.byteOffset, bytes.byteLength / 4), 1);
      }
      attributes.set(key, attr);
      return attr;
    }

    const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setClearColor(new THREE.Color(spec.background));
    const scene = new THREE.Scene();
    const camera = new THREE.PerspectiveCamera(35, 1, diag / 1000, diag * 50);
    // Scanner files are z-up (the turntable axis), calibration scenes y-down (the camera's frame);
    // keep that up on screen while orbiting.
    camera.up.fromArray(spec.up);
    scene.add(new THREE.HemisphereLight(0xffffff, 0x404048, 1.2));
    const headlight = new THREE.DirectionalLight(0xffffff, 1.8);
    headlight.position.set(0.3, 0.5, 1);
    camera.add(headlight);
    scene.add(camera);
    const controls = new THREE.OrbitControls(camera, canvas);

    function home() {
      const dir = new THREE.Vector3().fromArray(spec.home).normalize();
      camera.position.copy(centre).addScaledVector(dir, diag * 1.6);
      controls.target.copy(centre);
      controls.update();
    }

    let pending = false;
    function render() {
      if (pending) return;
      pending = true;
      requestAnimationFrame(() => {
        pending = false;
        renderer.render(scene, camera);
      });
    }
    function resize() {
      const w = canvas.clientWidth, h = canvas.clientHeight;
      if (w === 0 || h === 0) return;
      renderer.setSize(w, h, false);
      camera.aspect = w / h;
      camera.updateProjectionMatrix();
      render();
    }

    const objects = [];
    for (const layer of spec.layers) {
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', await attribute(layer.position, 'position'));
      const coloured = layer.colour !== null;
      if (coloured) geometry.setAttribute('color', await attribute(layer.colour, 'colour'));
      let object;
      if (layer.kind === 'points') {
        // Spacing of n samples over a surface about diag² in area, so the cloud reads as a surface.
        const pointSize = Math.max(diag / 2000, (1.5 * diag) / Math.sqrt(Math.max(layer.count, 1)));
        const material = new THREE.PointsMaterial({
          size: pointSize,
          vertexColors: coloured,
          color: coloured ? 0xffffff : 0xc8c8c8,
        });
        object = new THREE.Points(geometry, material);
        // Picking reaches as far as the layer's own points are drawn wide.
        object.userData.pointSize = pointSize;
      } else if (layer.kind === 'mesh') {
        geometry.setIndex(await attribute(layer.index, 'index'));
        geometry.computeVertexNormals();
        const material = new THREE.MeshStandardMaterial({
          vertexColors: coloured,
          color: coloured ? 0xffffff : 0xb4b8c0,
          roughness: 0.75,
          metalness: 0.0,
          side: THREE.DoubleSide,
        });
        object = new THREE.Mesh(geometry, material);
      } else if (layer.kind === 'lines') {
        geometry.setIndex(await attribute(layer.index, 'index'));
        object = new THREE.LineSegments(
          geometry,
          new THREE.LineBasicMaterial({ vertexColors: coloured, color: coloured ? 0xffffff : 0xe0e0e0 }),
        );
      } else {
        throw new Error('unknown layer kind ' + layer.kind);
      }
      object.visible = layer.visible;
      object.userData.layer = layer;
      scene.add(object);
      objects.push(object);
    }

    // One button per layer; a layer's legend shows while it does.
    const bar = document.getElementById('viewer-layers');
    const legends = document.getElementById('viewer-legend');
    function showLegends() {
      legends.innerHTML = '';
      for (const o of objects) {
        if (o.visible && o.userData.layer.legend) {
          const div = document.createElement('div');
          div.innerHTML = o.userData.layer.legend;
          legends.appendChild(div);
        }
      }
    }
    objects.forEach((o) => {
      const b = document.createElement('button');
      b.type = 'button';
      b.textContent = o.userData.layer.name;
      b.dataset.test = 'toggle';
      b.setAttribute('aria-pressed', String(o.visible));
      b.addEventListener('click', () => {
        const group = o.userData.layer.group;
        // Layers of one group (the mesh and its error colouring) replace each other.
        if (group && !o.visible) {
          for (const other of objects) {
            if (other !== o && other.userData.layer.group === group) {
              other.visible = false;
              other.userData.button.setAttribute('aria-pressed', 'false');
            }
          }
        }
        o.visible = !o.visible;
        b.setAttribute('aria-pressed', String(o.visible));
        showLegends();
        render();
      });
      o.userData.button = b;
      bar.appendChild(b);
    });
    showLegends();
    document.getElementById('viewer-reset').addEventListener('click', () => {
      home();
      render();
    });

    // Picking: a click (not a drag) reads the nearest visible point or surface under the cursor.
    const pick = document.getElementById('viewer-pick');
    const raycaster = new THREE.Raycaster();
    const marker = new THREE.Mesh(
      new THREE.SphereGeometry(diag / 250, 12, 8),
      new THREE.MeshBasicMaterial({ color: 0xff3060 }),
    );
    marker.visible = false;
    scene.add(marker);
    let down = null;
    canvas.addEventListener('pointerdown', (e) => (down = [e.clientX, e.clientY]));
    canvas.addEventListener('pointerup', (e) => {
      if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 4) return;
      const r = canvas.getBoundingClientRect();
      const ndc = new THREE.Vector2(((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1);
      raycaster.setFromCamera(ndc, camera);
      // Each layer with its own reach (clouds differ in density), the nearest hit of all.
      const hits = [];
      for (const o of objects) {
        if (!o.visible || o instanceof THREE.LineSegments) continue;
        raycaster.params.Points.threshold = o.userData.pointSize || 0;
        hits.push(...raycaster.intersectObject(o));
      }
      hits.sort((a, b) => a.distance - b.distance);
      if (hits.length === 0) {
        pick.textContent = 'Nothing under the cursor.';
        marker.visible = false;
      } else {
        const h = hits[0];
        const p = h.index !== undefined && h.object instanceof THREE.Points
          ? new THREE.Vector3().fromBufferAttribute(h.object.geometry.attributes.position, h.index)
          : h.point;
        marker.position.copy(p);
        marker.visible = true;
        const what = h.object.userData.layer.name + (h.object instanceof THREE.Points ? ', point ' + h.index : '');
        pick.textContent = `x ${p.x.toFixed(3)}  y ${p.y.toFixed(3)}  z ${p.z.toFixed(3)} ${spec.units} (${what})`;
      }
      render();
    });

    controls.addEventListener('change', render);
    new ResizeObserver(resize).observe(canvas);
    home();
    resize();
    renderer.render(scene, camera);
    const ms = performance.now();
    if (status) status.textContent = `Drawn ${(ms / 1000).toFixed(2)} s after the page started loading.`;
    window.scanrigOpenSeconds = ms / 1000;
    window.scanrigReady = true;
  }

  main().catch(fail);
})();
