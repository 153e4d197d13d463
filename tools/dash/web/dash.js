'use strict';
// The page of `pof dash` (docs/dashboard.md). One WebSocket; each message is a frame: per sensor,
// the chart points this browser has not seen (or the whole window with reset=true), the cycles it
// has not seen, and the latest health. Drawing is paced by the browser (requestAnimationFrame), so
// frames that arrive faster than the screen can draw are merged, never queued.
(function () {
  const ANGLE_STALE_S = 0.5;   // no angle for longer: the readout says so in red
  const LOOP_S = 10;           // the loop chart's history
  const CYCLES_SHOWN = 50;

  // Everything the page knows; the browser test (tests/e2e/dash_browser.py) reads it.
  const state = {
    connected: false, frames: 0, bytes: 0, resets: 0, lastFrame: null, lastFrameAt: 0,
    sensors: new Map(), selected: null, windowS: 20, renders: 0, renderMs: [],
  };
  window.pofDash = state;

  const $ = (id) => document.getElementById(id);
  const fmt = (v, d) => (v === null || v === undefined || Number.isNaN(v)) ? '–' : Number(v).toFixed(d);

  function sensorState(id) {
    let s = state.sensors.get(id);
    if (!s) {
      s = { id, t: [], angle: [], uncomp: [], ref: [], sigma: [], quality: [], cycles: [], cyclesTotal: 0, info: null };
      state.sensors.set(id, s);
      const opt = document.createElement('option');
      opt.value = id;
      opt.textContent = id === '' ? '(no sensor id)' : id;
      $('sensor').appendChild(opt);
      if (state.selected === null) state.selected = id;
    }
    return s;
  }

  const KEYS = ['t', 'angle', 'uncomp', 'ref', 'sigma', 'quality'];
  function merge(s, f, windowS) {
    if (f.reset) { KEYS.forEach((k) => { s[k] = []; }); state.resets++; }
    KEYS.forEach((k) => { for (const v of f.points[k]) s[k].push(v); });
    if (s.t.length === 0) return;
    const oldest = s.t[s.t.length - 1] - windowS;
    let drop = 0;
    while (drop < s.t.length && s.t[drop] < oldest) drop++;
    if (drop > 0) KEYS.forEach((k) => { s[k].splice(0, drop); });
  }

  function onFrame(frame) {
    state.frames++;
    state.lastFrame = frame;
    state.lastFrameAt = performance.now();
    for (const f of frame.sensors) {
      const s = sensorState(f.id);
      merge(s, f, frame.window_s);
      for (const c of f.cycles) s.cycles.unshift(c);
      if (s.cycles.length > CYCLES_SHOWN) s.cycles.length = CYCLES_SHOWN;
      s.cyclesTotal = f.cycles_total;
      s.info = f;
    }
    scheduleRender();
  }

  // --- charts (Chart.js 3, Debian's libjs-chart.js) ---
  const common = {
    animation: false, responsive: true, maintainAspectRatio: false,
    interaction: { mode: 'nearest', intersect: false },
    plugins: { legend: { position: 'bottom' }, tooltip: { enabled: true } },
  };
  const timeChart = new Chart($('timeChart'), {
    type: 'line',
    data: { datasets: [
      { label: 'angle (compensated)', data: [], borderColor: '#1f5fbf', backgroundColor: '#1f5fbf', borderWidth: 2, pointRadius: 0 },
      { label: 'reference', data: [], borderColor: '#1d2430', backgroundColor: '#1d2430', borderDash: [6, 4], borderWidth: 1.5, pointRadius: 0 },
      { label: 'uncompensated', data: [], borderColor: '#9aa3ad', backgroundColor: '#9aa3ad', borderWidth: 1, pointRadius: 0 },
      { label: 'flagged', data: [], borderColor: '#b3261e', backgroundColor: '#b3261e', showLine: false, pointRadius: 2 },
    ] },
    options: Object.assign({}, common, {
      // Times only increase: the points go in as they are (no parsing) and may be bisected.
      parsing: false, normalized: true,
      scales: { x: { type: 'linear', title: { display: true, text: 'time before the last angle [s]' } },
        y: { title: { display: true, text: 'deg' } } },
      plugins: Object.assign({}, common.plugins, { decimation: { enabled: true, algorithm: 'min-max' } }),
    }),
  });
  const loopChart = new Chart($('loopChart'), {
    type: 'scatter',
    data: { datasets: [
      { label: 'compensated', data: [], borderColor: '#1f5fbf', backgroundColor: '#1f5fbf', pointRadius: 1 },
      { label: 'uncompensated', data: [], borderColor: '#9aa3ad', backgroundColor: '#9aa3ad', pointRadius: 1 },
    ] },
    options: Object.assign({}, common, {
      parsing: true,  // Chart.js 3 takes unparsed data as sorted by x, which a loop is not
      scales: { x: { type: 'linear', title: { display: true, text: 'reference [deg]' } }, y: { title: { display: true, text: 'angle [deg]' } } },
    }),
  });

  // {x, y} points from index `from` on, x shifted by `x0`; a null (NaN on the bus) is left out.
  function xy(xs, ys, from, x0) {
    const out = [];
    for (let i = from; i < xs.length; i++) if (ys[i] !== null && xs[i] !== null) out.push({ x: xs[i] - x0, y: ys[i] });
    return out;
  }

  function firstAfter(t, tmin) {
    let i = 0;
    while (i < t.length && t[i] < tmin) i++;
    return i;
  }

  function renderCharts(s) {
    const tEnd = s.t.length ? s.t[s.t.length - 1] : 0;
    const from = firstAfter(s.t, tEnd - state.windowS);
    const ds = timeChart.data.datasets;
    ds[0].data = xy(s.t, s.angle, from, tEnd);
    ds[1].data = xy(s.t, s.ref, from, tEnd);
    ds[2].data = xy(s.t, s.uncomp, from, tEnd);
    const flagged = [];
    for (let i = from; i < s.t.length; i++) if (s.quality[i] !== 0 && s.angle[i] !== null) flagged.push({ x: s.t[i] - tEnd, y: s.angle[i] });
    ds[3].data = flagged;
    timeChart.options.scales.x.min = -state.windowS;
    timeChart.options.scales.x.max = 0;
    timeChart.update('none');
    const lfrom = firstAfter(s.t, tEnd - LOOP_S);
    loopChart.data.datasets[0].data = xy(s.ref, s.angle, lfrom, 0);
    loopChart.data.datasets[1].data = xy(s.ref, s.uncomp, lfrom, 0);
    loopChart.update('none');
  }

  function renderReadout(s, frame) {
    const f = s.info;
    const a = f && f.latest;
    $('angle').textContent = a ? fmt(a.angle_deg, 2) + '°' : '–';
    $('ref').textContent = a ? fmt(a.angle_ref_deg, 2) + '°' : '–';
    $('uncomp').textContent = a ? fmt(a.angle_uncomp_deg, 2) + '°' : '–';
    const err = a && a.angle_deg !== null && a.angle_ref_deg !== null ? a.angle_deg - a.angle_ref_deg : null;
    $('err').textContent = err === null ? '–' : fmt(err, 2) + '°';
    $('quality').textContent = a ? a.quality_names : '–';
    $('quality').className = 'value small' + (a && a.quality !== 0 ? ' warn' : '');
    const age = f ? f.angle_age_s : -1;
    const stale = age < 0 || age > ANGLE_STALE_S;
    $('age').textContent = age < 0 ? 'none yet' : (stale ? 'no angle for ' + fmt(age, 1) + ' s' : fmt(age * 1000, 0) + ' ms ago');
    $('age').className = 'value small' + (stale ? ' bad' : '');
    $('angle').className = 'value' + (stale ? ' bad' : '');
    $('cycleCount').textContent = '(' + s.cyclesTotal + ' so far)';
    const rows = s.cycles.map((c) => '<tr><td>' + c.cycle + '</td><td>' + fmt(c.velocity_rad_s, 3) + '</td><td>' +
      fmt(c.rmse_comp_deg, 3) + '</td><td>' + fmt(c.rmse_uncomp_deg, 3) + '</td><td>' + fmt(c.hysteresis_comp_pct, 2) +
      '</td><td>' + fmt(c.hysteresis_uncomp_pct, 2) + '</td><td>' + fmt(c.max_error_deg, 3) + '</td><td>' + c.n_samples + '</td></tr>');
    $('cycles').tBodies[0].innerHTML = rows.join('');
  }

  function cell(v, bad) { return '<td' + (bad ? ' class="bad"' : '') + '>' + v + '</td>'; }
  function esc(t) { return String(t).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c])); }

  function renderHealth(frame) {
    const rows = [];
    for (const f of frame.sensors) {
      const d = f.daq, c = f.compensator;
      const daqState = d ? d.state_name + (d.state_text ? ': ' + d.state_text : '') : 'no status';
      rows.push('<tr>' + cell(esc(f.id === '' ? '(none)' : f.id)) +
        cell(esc(daqState), !d || d.state_name !== 'STREAMING' || f.daq_age_s > 3) +
        cell(d ? d.scans : '–') + cell(d ? d.dropped_scans : '–', d && d.dropped_scans > 0) +
        cell(d ? d.usb_errors : '–', d && d.usb_errors > 0) + cell(d ? d.reconnects : '–', d && d.reconnects > 0) +
        cell(fmt(f.angle_rate_hz, 0), f.angle_age_s < 0 || f.angle_age_s > ANGLE_STALE_S) +
        cell(f.angles_flagged) + cell(f.angles_missing, f.angles_missing > 0) +
        cell(c ? c.lost_scans : '–', c && c.lost_scans > 0) + cell(c ? c.rejected_blocks : '–', c && c.rejected_blocks > 0) +
        cell(c ? c.reload_failures : '–', c && c.reload_failures > 0) + cell(c ? c.estimator_divergences : '–') +
        cell(c && c.last_error ? esc(c.last_error) : '', c && c.last_error) + '</tr>');
    }
    $('health').tBodies[0].innerHTML = rows.join('');
    const b = frame.bus;
    $('bus').textContent = 'bus ' + b.url + (b.authenticated ? ' · authenticated: ' + b.auth_dropped + ' dropped' : ' · unauthenticated') +
      ' · malformed ' + b.malformed_datagrams + ' · decode errors ' + b.decode_errors + ' · kernel drops ' + b.kernel_drops +
      ' · browsers ' + b.clients + ' · frames skipped ' + b.frames_skipped +
      (frame.ignored_sensors > 0 ? ' · ignored sensors ' + frame.ignored_sensors : '');
  }

  // The charts redraw at most CHART_HZ times a second (the numbers at every frame): a chart of a
  // few thousand points is the page's whole cost, and a tablet beside the patient, or the host
  // that also runs the daemons, has better use for the CPU than redrawing faster than an eye reads.
  const CHART_HZ = 10;
  let pending = false, lastChart = -Infinity;
  function scheduleRender() {
    if (pending) return;
    pending = true;
    requestAnimationFrame((now) => {
      pending = false;
      const t0 = performance.now();
      const frame = state.lastFrame;
      const s = state.sensors.get(state.selected);
      if (s && now - lastChart >= 1000 / CHART_HZ) { renderCharts(s); lastChart = now; }
      else if (s) setTimeout(scheduleRender, 1000 / CHART_HZ - (now - lastChart));
      if (s) renderReadout(s, frame);
      renderHealth(frame);
      state.renders++;
      state.renderMs.push(performance.now() - t0);
      if (state.renderMs.length > 500) state.renderMs.shift();
    });
  }

  state.charts = { time: timeChart, loop: loopChart };
  $('sensor').addEventListener('change', (e) => { state.selected = e.target.value; lastChart = -Infinity; scheduleRender(); });
  $('window').addEventListener('change', (e) => { state.windowS = Number(e.target.value); lastChart = -Infinity; scheduleRender(); });

  function link(text, cls) { $('link').textContent = text; $('link').className = 'pill ' + cls; }
  function connect() {
    const ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/ws');
    ws.onopen = () => { state.connected = true; link('live', 'ok'); };
    ws.onmessage = (m) => { state.bytes += m.data.length; onFrame(JSON.parse(m.data)); };
    ws.onclose = () => {
      state.connected = false;
      link('disconnected: retrying', 'bad');
      setTimeout(connect, 1000);
    };
  }
  setInterval(() => {  // frames stopped without the socket closing (server stuck, network gone)
    if (state.connected && performance.now() - state.lastFrameAt > 2000) link('no updates', 'warn');
    else if (state.connected) link('live', 'ok');
  }, 500);
  connect();
})();
