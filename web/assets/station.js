// scanrig station: the page of `scanrig serve`. Everything it shows comes from the station's JSON API
// (/api/…) and its one event stream (/api/events, server-sent events); every button that drives the
// rig sends the control token this page was given when it took control, so a second browser only
// watches. No algorithm here: the station runs the library, the page draws what it says.
(function () {
  'use strict';

  const $ = (id) => document.getElementById(id);
  const query = new URLSearchParams(location.search);
  // A station bound beyond the loopback interface asks every request for the token it printed.
  const accessToken = query.get('token');
  let control = sessionStorage.getItem('scanrig-control');
  let state = null;
  let events = null;
  const log = [];

  function say(text, kind) {
    const d = document.createElement('div');
    if (kind === 'info') d.className = 'info';
    d.textContent = text;
    const box = $('messages');
    box.prepend(d);
    while (box.children.length > 4) box.lastChild.remove();
  }

  // The timing log: what the operator test reads (each view's time from capture to screen, clicks).
  function note(line) {
    log.push(line);
    $('live-log').textContent = log.join('\n');
  }

  async function api(method, path, body) {
    const headers = { 'Content-Type': 'application/json' };
    if (control) headers['X-Scanrig-Control'] = control;
    if (accessToken) headers['X-Scanrig-Token'] = accessToken;
    const r = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
    let data = {};
    try { data = await r.json(); } catch (e) { data = {}; }
    if (!r.ok) {
      const e = new Error(data.error || 'the station answered ' + r.status);
      e.status = r.status;
      throw e;
    }
    return data;
  }

  // A button's work: its failure is said on the page (the station's message names what to fix).
  function action(fn) {
    return async () => {
      try { await fn(); } catch (e) { say(e.message); }
    };
  }

  function on(id, fn) { $(id).addEventListener('click', action(fn)); }

  // --- control -------------------------------------------------------------------------------
  function showControl() {
    const mine = !!control;
    const taken = state && state.controlled;
    $('control-state').textContent = mine ? 'This page controls the rig.'
      : taken ? 'Read-only: another operator controls the rig.' : 'Nobody controls the rig.';
    $('take-control').hidden = mine;
    $('release-control').hidden = !mine;
    const busy = state && state.job;
    for (const b of document.querySelectorAll('.ctl')) b.disabled = !mine;
    $('scan-stop').disabled = !mine || !(busy && busy.kind === 'scan');
  }

  async function takeControl(offered) {
    const r = await api('POST', '/api/control', offered ? { token: offered } : {});
    control = r.token;
    sessionStorage.setItem('scanrig-control', control);
    connect();
    showControl();
  }

  // The station pings every page on its event stream; the page in control answers, which is how
  // the station tells an open page from one whose laptop went to sleep with its stream still open.
  // An event's handler runs in a hidden tab too (timers there are throttled to once a minute). A
  // page waking from sleep gets every ping the station wrote meanwhile at once: one answer at a
  // time, and a refusal acted on only if the token it was for is still the page's.
  let answering = false;
  async function answerPing() {
    if (!control || answering) return;
    const sent = control;
    answering = true;
    try {
      await api('POST', '/api/alive', {});
    } catch (e) {
      if (e.status !== 409 || control !== sent) return;
      control = null;
      sessionStorage.removeItem('scanrig-control');
      connect();
      showControl();
      say('This page no longer controls the rig (it went unheard for too long, or the station restarted): ' + e.message);
    } finally {
      answering = false;
    }
  }

  on('take-control', () => takeControl(null));
  on('release-control', async () => {
    await api('POST', '/api/release', {});
    control = null;
    sessionStorage.removeItem('scanrig-control');
    connect();
    showControl();
  });

  // --- tabs ----------------------------------------------------------------------------------
  function showTab(name) {
    for (const s of document.querySelectorAll('section.tab')) s.hidden = s.id !== name;
    for (const a of document.querySelectorAll('#tabs a')) a.classList.toggle('active', a.dataset.tab === name);
    if (name === 'scan') viewer.resize();
    if (name === 'projects') refreshProjects().catch((e) => say(e.message));
  }
  for (const a of document.querySelectorAll('#tabs a')) {
    a.addEventListener('click', (e) => { e.preventDefault(); history.replaceState(null, '', location.pathname + location.search + '#' + a.dataset.tab); showTab(a.dataset.tab); });
  }

  // --- state ---------------------------------------------------------------------------------
  function showState(s) {
    state = s;
    const d = s.devices;
    const sel = $('dev-turntable');
    if (sel.options.length !== d.ports.length) {
      sel.replaceChildren(...d.ports.map((p) => new Option(p === 'virtual' ? 'virtual turntable' : p, p)));
    }
    sel.value = d.turntable;
    if (document.activeElement !== $('dev-camera')) $('dev-camera').value = d.camera;
    $('rig-state').textContent = (s.rig.calibrated ? 'calibrated, ' : 'not calibrated yet (the virtual rig\'s own), ') + s.rig.path;
    $('data-dir').textContent = s.data;
    if (!$('scan-views').value) $('scan-views').value = s.views;
    if (document.activeElement !== $('live-exposure')) $('live-exposure').value = s.exposure;
    if (document.activeElement !== $('live-projector')) $('live-projector').value = s.projector ? s.projector : 'off';
    $('live-projector-where').textContent = s.projector_window
      ? 'shown in the ' + s.projector_window
      : 'simulated (a real projector needs scanrig serve --projector-monitor N)';
    if (d.unplugged) $('rig-state').textContent += '; the virtual turntable is unplugged (a scan started now plugs in a new one)';
    showControl();
  }

  // --- devices and check ---------------------------------------------------------------------
  on('dev-use', async () => {
    showState(await api('POST', '/api/devices', { turntable: $('dev-turntable').value, camera: $('dev-camera').value }));
    say('Devices set.', 'info');
  });
  on('check-run', () => api('POST', '/api/check', {}));
  on('manual-turn', async () => say((await api('POST', '/api/turntable', { angle: Number($('manual-angle').value) })).done, 'info'));
  on('manual-laser-on', async () => say((await api('POST', '/api/turntable', { laser: 0, on: true })).done, 'info'));
  on('manual-laser-off', async () => say((await api('POST', '/api/turntable', { laser: 0, on: false })).done, 'info'));
  on('fault-unplug', async () => { await api('POST', '/api/fault/unplug', {}); say('The virtual turntable\'s cable is out.', 'info'); });

  function showCheck(ev) {
    const list = $('check-results');
    if (ev.name === 'start') { list.replaceChildren(); return; }
    if (ev.name === 'end') { list.dataset.done = 'yes'; return; }
    const li = document.createElement('li');
    li.className = ev.ok === true ? 'yes' : ev.ok === false ? 'no' : 'skip';
    li.dataset.check = ev.name;
    li.textContent = ev.name + ': ' + ev.detail + (ev.todo ? ' — ' + ev.todo : '');
    list.appendChild(li);
  }

  // --- live view -----------------------------------------------------------------------------
  let liveBusy = false;
  async function takeFrame() {
    if (liveBusy) return;
    liveBusy = true;
    try {
      const r = await api('GET', '/api/live?show=' + encodeURIComponent($('live-show').value));
      $('live-image').src = r.image;
      $('live-note').textContent = r.note || '';
      $('live-warning').textContent = r.warning || '';
    } finally { liveBusy = false; }
  }
  on('live-take', takeFrame);
  on('live-exposure-set', async () => { await api('POST', '/api/camera', { exposure: Number($('live-exposure').value) }); await takeFrame(); });
  on('live-projector-set', async () => { await api('POST', '/api/projector', { pattern: $('live-projector').value }); await takeFrame(); });
  setInterval(() => {
    if ($('live-auto').checked && !$('live').hidden && !(state && state.job)) takeFrame().catch((e) => say(e.message));
  }, 800);

  // --- calibration ---------------------------------------------------------------------------
  let wizard = null;
  function showWizard(w) {
    wizard = w;
    $('calib-next').textContent = w.next.say;
    const c = $('calib-coverage');
    const g = c.getContext('2d');
    const cov = w.coverage;
    const sx = c.width / cov.width, sy = c.height / cov.height;
    g.clearRect(0, 0, c.width, c.height);
    const most = Math.max(1, ...cov.cells);
    for (let j = 0; j < cov.rows; j++) {
      for (let i = 0; i < cov.cols; i++) {
        const n = cov.cells[j * cov.cols + i];
        g.fillStyle = 'rgba(31,95,191,' + (0.08 + 0.8 * n / most).toFixed(3) + ')';
        if (n > 0) g.fillRect(i * c.width / cov.cols, j * c.height / cov.rows, c.width / cov.cols - 1, c.height / cov.rows - 1);
      }
    }
    if (w.next.outline && w.next.outline.length === 4) {
      g.strokeStyle = '#d9480f';
      g.lineWidth = 2;
      g.beginPath();
      w.next.outline.forEach((p, k) => (k ? g.lineTo(p[0] * sx, p[1] * sy) : g.moveTo(p[0] * sx, p[1] * sy)));
      g.closePath();
      g.stroke();
    }
    const box = $('calib-captures');
    box.replaceChildren(...w.captures.map((cap) => {
      const f = document.createElement('figure');
      f.className = cap.accepted === true ? 'accepted' : cap.accepted === false ? 'rejected' : '';
      const img = new Image();
      img.src = cap.picture + '?v=' + (cap.found ? 1 : 0) + (accessToken ? '&token=' + encodeURIComponent(accessToken) : '');
      img.alt = 'capture ' + cap.index;
      const cap_ = document.createElement('figcaption');
      cap_.textContent = (cap.kind === 'held' ? 'held pose' : 'sweep ' + cap.angle_deg + '°') + ': ' +
        (cap.found ? cap.corners + ' corners' : 'board not found');
      const yes = document.createElement('button');
      yes.textContent = 'Accept';
      yes.className = 'ctl';
      yes.disabled = !control || !cap.found;
      yes.addEventListener('click', action(async () => showWizard(await api('POST', '/api/calibrate/review', { index: cap.index, accept: true }))));
      const no = document.createElement('button');
      no.textContent = 'Reject';
      no.className = 'ctl';
      no.disabled = !control;
      no.addEventListener('click', action(async () => showWizard(await api('POST', '/api/calibrate/review', { index: cap.index, accept: false }))));
      f.append(img, cap_, yes, no);
      return f;
    }));
  }
  on('calib-held', () => api('POST', '/api/calibrate/capture', { kind: 'held' }));
  on('calib-sweep', () => api('POST', '/api/calibrate/capture', { kind: 'sweep' }));
  on('calib-accept-all', async () => {
    // The station's list, not this page's copy: a capture's event may still be on its way.
    const now = await api('GET', '/api/calibration');
    for (const c of now.captures) {
      if (c.found && c.accepted === null) await api('POST', '/api/calibrate/review', { index: c.index, accept: true });
    }
    showWizard(await api('GET', '/api/calibration'));
    $('calib-captures').dataset.reviewed = 'all';
  });
  on('calib-run', () => { $('calib-result').textContent = 'Calibrating…'; return api('POST', '/api/calibrate/run', {}); });
  on('calib-reset', async () => showWizard(await api('POST', '/api/calibrate/reset', {})));

  function showCalibrated(ev) {
    const box = $('calib-result');
    box.replaceChildren();
    const p = document.createElement('p');
    p.className = ev.ok ? 'ok' : 'warn';
    p.textContent = ev.ok ? 'Calibrated: the rig is saved in ' + ev.rig + (ev.rms_px != null ? ' (camera RMS ' + Number(ev.rms_px).toFixed(3) + ' px).' : '.')
      : 'Not saved: ' + ev.message;
    box.appendChild(p);
    if (ev.report) {
      const a = document.createElement('a');
      a.href = ev.report + (accessToken ? '?token=' + encodeURIComponent(accessToken) : '');
      a.target = '_blank';
      a.id = 'calib-report';
      a.textContent = 'The calibration report';
      box.appendChild(a);
    }
  }

  // --- the 3D view -------------------------------------------------------------------------
  const viewer = (function () {
    let renderer = null, scene, camera, controls, count = 0;
    const bounds = new THREE.Box3();
    function init() {
      if (renderer) return;
      const canvas = $('viewer3d');
      renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
      renderer.setPixelRatio(window.devicePixelRatio || 1);
      renderer.setClearColor(0xf5f6f8);
      scene = new THREE.Scene();
      camera = new THREE.PerspectiveCamera(35, 1.6, 1, 20000);
      camera.up.set(0, 0, 1);
      camera.position.set(0, -400, 200);
      controls = new THREE.OrbitControls(camera, canvas);
      controls.addEventListener('change', render);
      resize();
    }
    function resize() {
      if (!renderer) return;
      const c = renderer.domElement;
      const w = c.clientWidth || 800, h = c.clientHeight || 500;
      renderer.setSize(w, h, false);
      camera.aspect = w / h;
      camera.updateProjectionMatrix();
      render();
    }
    function render() { if (renderer) renderer.render(scene, camera); }
    function frame() {
      if (bounds.isEmpty()) return;
      const centre = bounds.getCenter(new THREE.Vector3());
      const size = bounds.getSize(new THREE.Vector3()).length() || 100;
      controls.target.copy(centre);
      camera.position.set(centre.x, centre.y - 1.6 * size, centre.z + 0.8 * size);
      camera.near = size / 100;
      camera.far = size * 50;
      camera.updateProjectionMatrix();
      controls.update();
    }
    function clear() {
      if (!renderer) return;
      for (const o of [...scene.children]) { scene.remove(o); o.geometry.dispose(); o.material.dispose(); }
      bounds.makeEmpty();
      count = 0;
      $('viewer-count').textContent = 'No view yet.';
      render();
    }
    function add(view, flat) {
      init();
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(flat, 3));
      g.computeBoundingBox();
      if (flat.length) bounds.union(g.boundingBox);
      const colour = new THREE.Color().setHSL((view * 0.137) % 1, 0.65, 0.45);
      scene.add(new THREE.Points(g, new THREE.PointsMaterial({ size: 2, sizeAttenuation: false, color: colour })));
      count += 1;
      if (count <= 3) frame();
      $('viewer-count').textContent = count + ' view' + (count === 1 ? '' : 's') + ' shown';
      render();
    }
    $('viewer-reset').addEventListener('click', () => { frame(); render(); });
    window.addEventListener('resize', resize);
    return { add, clear, resize, init };
  })();

  // --- scan and process ----------------------------------------------------------------------
  on('scan-start', async () => {
    const views = $('scan-views').value ? Number($('scan-views').value) : null;
    viewer.clear();
    $('badges').replaceChildren();
    $('process-result').replaceChildren();
    await api('POST', '/api/scan', { project: $('scan-project').value, views });
  });
  on('scan-stop', () => api('POST', '/api/scan/stop', {}));
  on('process-start', () => api('POST', '/api/process', { project: $('scan-project').value }));

  function showCaptured(ev) {
    $('scan-progress').max = ev.total;
    $('scan-progress').value = ev.done;
    const left = ev.eta_s != null ? ', about ' + Math.ceil(ev.eta_s) + ' s left' : '';
    $('scan-status').textContent = 'View ' + ev.done + ' of ' + ev.total + ' captured' + left + '.';
  }

  function showView(ev) {
    viewer.add(ev.view, ev.points);
    // A view captured before a resume is shown again, not timed.
    if (ev.captured_ms != null) note('view ' + ev.view + ' shown ' + (Date.now() - ev.captured_ms).toFixed(0) + ' ms after its capture');
    const b = document.createElement('span');
    const warned = ev.badge.warnings.length > 0;
    const poor = ev.badge.coverage < 0.5;
    b.className = 'badge' + (warned || poor ? ' bad' : '');
    b.dataset.view = ev.view;
    b.title = warned ? ev.badge.warnings.join('\n') : 'no warning';
    b.textContent = 'view ' + ev.view + ' (' + ev.angle_deg.toFixed(0) + '°): ' + ev.badge.points + ' points, ' +
      (100 * ev.badge.coverage).toFixed(0) + ' % decoded' + (warned ? ', ' + ev.badge.warnings.length + ' warning(s)' : '');
    $('badges').appendChild(b);
  }

  function showScan(ev) {
    const s = $('scan-status');
    s.dataset.state = ev.state;
    if (ev.state === 'running') {
      s.textContent = (ev.resumed ? 'Resuming ' : 'Scanning ') + ev.project + '…';
      $('messages').replaceChildren();
    }
    if (ev.state === 'complete') s.textContent = ev.project + ': all ' + ev.total + ' views captured. Process it next.';
    if (ev.state === 'stopped') s.textContent = ev.message;
    if (ev.state === 'failed') {
      // The reason comes as the job's fault message.
      s.textContent = 'Stopped by a fault: ' + ev.complete + ' of ' + ev.total + ' views are kept; Start resumes.';
    }
  }

  function showStage(ev) {
    $('process-progress').max = Math.max(1, ev.total);
    $('process-progress').value = ev.done;
    $('process-status').textContent = ev.project + ': ' + ev.stage + ' ' + ev.done + ' of ' + ev.total;
  }

  function link(href, text, id) {
    const a = document.createElement('a');
    a.href = href + (accessToken ? '?token=' + encodeURIComponent(accessToken) : '');
    a.textContent = text;
    if (id) a.id = id;
    return a;
  }

  function showProcessed(ev) {
    const box = $('process-result');
    box.replaceChildren();
    $('process-status').textContent = ev.project + ': processed in ' + ev.seconds.toFixed(1) + ' s.';
    if (ev.report) {
      const a = link(ev.report, 'Open the report', 'report-link');
      a.target = '_blank';
      box.append(a, document.createTextNode(' · '));
    }
    for (const d of ev.downloads) {
      const a = link(d.href, d.name);
      a.title = d.what;
      a.className = 'download';
      box.append(a, document.createTextNode(' '));
    }
    if (ev.warnings.length) {
      const ul = document.createElement('ul');
      ul.className = 'warnings';
      for (const w of ev.warnings) { const li = document.createElement('li'); li.textContent = w; ul.appendChild(li); }
      box.appendChild(ul);
    }
  }

  // --- projects ------------------------------------------------------------------------------
  async function refreshProjects() {
    const t0 = performance.now();
    const r = await api('GET', '/api/projects');
    const body = $('projects-table').tBodies[0];
    body.replaceChildren(...r.projects.map((p) => {
      const tr = document.createElement('tr');
      tr.dataset.project = p.name;
      const cell = (x, cls) => { const td = document.createElement('td'); if (cls) td.className = cls; if (x instanceof Node) td.appendChild(x); else td.textContent = x; return td; };
      const open = p.report ? link(p.report, 'report') : document.createTextNode('');
      if (p.report) open.target = '_blank';
      const dl = document.createElement('span');
      for (const d of p.downloads) { const a = link(d.href, d.name); a.title = d.what; dl.append(a, document.createTextNode(' ')); }
      const pick = document.createElement('button');
      pick.textContent = p.complete < p.total ? 'Resume' : 'Select';
      pick.className = 'ctl';
      pick.disabled = !control;
      pick.addEventListener('click', () => { $('scan-project').value = p.name; $('scan-views').value = p.total; showTab('scan'); });
      tr.append(cell(p.name), cell(p.complete + ' / ' + p.total, 'num'), cell(p.state), cell(open), cell(dl), cell(pick));
      return tr;
    }));
    const ms = performance.now() - t0;
    $('projects-answered').textContent = 'answered in ' + ms.toFixed(0) + ' ms';
    note('projects answered in ' + ms.toFixed(0) + ' ms' + (state && state.job ? ' during ' + state.job.kind : ''));
  }
  on('projects-refresh', refreshProjects);

  // --- the event stream ----------------------------------------------------------------------
  function connect() {
    if (events) events.close();
    const q = new URLSearchParams();
    if (control) q.set('control', control);
    if (accessToken) q.set('token', accessToken);
    events = new EventSource('/api/events?' + q.toString());
    const handlers = {
      state: showState,
      check: showCheck,
      captured: showCaptured,
      view: showView,
      scan: showScan,
      stage: showStage,
      processed: showProcessed,
      calibration: showWizard,
      calibrated: showCalibrated,
      ping: answerPing,
      'view-failed': (ev) => say('View ' + ev.view + ' could not be shown: ' + ev.message),
      fault: (ev) => say(ev.job + (ev.project ? ' ' + ev.project : '') + ': ' + ev.message),
    };
    for (const [kind, fn] of Object.entries(handlers)) {
      events.addEventListener(kind, (e) => {
        try { fn(JSON.parse(e.data)); } catch (err) { say('The page could not show a ' + kind + ' event: ' + err.message); }
      });
    }
  }

  async function start() {
    showState(await api('GET', '/api/state'));
    if (control) {
      try { await takeControl(control); } catch (e) { control = null; sessionStorage.removeItem('scanrig-control'); }
    }
    connect();
    showWizard(await api('GET', '/api/calibration'));
    showTab((location.hash || '#devices').slice(1).split('?')[0] || 'devices');
    document.body.dataset.ready = 'yes';
  }
  start().catch((e) => say(e.message));
})();
