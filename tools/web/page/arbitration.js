// The arbitrated port's panel: the winner, the event container (time left counting down), each
// connection's constraint and S x y, and the plot of the last 60 s with the winner band under it
// (docs/fetch-timeline.svg, live).

import { el, setText, fmtNum, colourOf, carrierKind, carrierScripts, arr, num } from './util.js';

export const WINDOW_S = 60;
const KEEP_S = 65;

// The 20 Hz history of every arbitrated port, kept for all of them so that switching ports shows
// the past minute at once.
export class History {
  constructor() { this.ports = new Map(); }

  add(t, p, recv) {
    if (!p || typeof p.port !== 'string') return;
    let h = this.ports.get(p.port);
    if (!h) { h = { samples: [], sources: [] }; this.ports.set(p.port, h); }
    const conns = new Map();
    for (const c of arr(p.connections)) {
      if (!c || typeof c.source !== 'string') continue;
      conns.set(c.source, { S: num(c.S), x: num(c.x), y: num(c.y) });
      if (!h.sources.includes(c.source)) { h.sources.push(c.source); colourOf(p.port, c.source); }
    }
    const last = h.samples[h.samples.length - 1];
    if (last && t < last.t) h.samples.length = 0;       // the daemon's clock went back: start again
    h.samples.push({ t, recv, winner: typeof p.winner === 'string' ? p.winner : null, conns,
      events: arr(p.events).map((e) => e && e.name).filter((n) => typeof n === 'string') });
    let drop = 0;
    while (drop < h.samples.length && h.samples[drop].t < t - KEEP_S) drop++;
    if (drop) h.samples.splice(0, drop);
    h.latest = p; h.latestT = t; h.latestRecv = recv;
  }

  // Points received (browser clock) in the last `seconds`, per connection.
  points(port, seconds) {
    const out = {};
    const h = this.ports.get(port);
    if (!h) return out;
    const since = performance.now() - seconds * 1000;
    for (let i = h.samples.length - 1; i >= 0 && h.samples[i].recv >= since; i--) {
      for (const s of h.samples[i].conns.keys()) out[s] = (out[s] || 0) + 1;
    }
    return out;
  }
}

export class ArbitrationPanel {
  constructor(history) {
    this.history = history;
    this.port = null;
    this.e = {
      winner: document.getElementById('winner'),
      port: document.getElementById('arb-port'),
      inconsistent: document.getElementById('inconsistent'),
      events: document.getElementById('events'),
      list: document.getElementById('connection-list'),
      plot: document.getElementById('plot'),
    };
    this.rows = new Map();        // source -> row elements
    this.eventRows = new Map();   // event name+owner -> row
    this.docs = new Map();        // port -> its events document from /api/system (counters, carrier, aux)
    this.inbound = new Set();     // ports with connections in, from the graph
    this.plot = null;
    this.plotKey = '';
    this.dirty = false;
    new ResizeObserver(() => this.resizePlot()).observe(this.e.plot);
    const frame = () => { this.tick(); requestAnimationFrame(frame); };
    requestAnimationFrame(frame);
  }

  setDocs(docs, inbound) { this.docs = docs; this.inbound = inbound; this.changed(); }

  select(port) {
    if (port === this.port) return;
    this.port = port;
    this.e.list.replaceChildren(); this.rows.clear();
    this.e.events.replaceChildren(); this.eventRows.clear();
    setText(this.e.port, port ? `of ${port}` : '');
    this.rebuildPlot();
    this.render();
  }

  // A new 20 Hz snapshot arrived (for any port).
  changed() { this.dirty = true; }

  latest() {
    const h = this.history.ports.get(this.port);
    if (h && h.latest) return { p: h.latest, recv: h.latestRecv, h };
    const doc = this.docs.get(this.port);
    if (doc) return { p: doc, recv: doc._recv, h: null };
    return null;
  }

  render() {
    const cur = this.latest();
    const arbitrated = cur !== null;
    setText(this.e.winner, cur && typeof cur.p.winner === 'string' ? cur.p.winner : 'none');
    this.e.winner.classList.toggle('none', !(cur && typeof cur.p.winner === 'string'));
    this.e.winner.style.color = cur && typeof cur.p.winner === 'string' ? colourOf(this.port, cur.p.winner) : '';
    const doc = this.docs.get(this.port);
    const why = doc && typeof doc.inconsistent === 'string' ? doc.inconsistent : '';
    this.e.inconsistent.hidden = !why;
    setText(this.e.inconsistent, why ? `inconsistent: ${why}` : '');
    if (!arbitrated) {
      if (!this.e.list.firstChild || !this.e.list.firstChild.classList.contains('empty')) {
        this.e.list.replaceChildren(el('div', { class: 'empty' }));
        this.rows.clear();
      }
      setText(this.e.list.firstChild, !this.port ? 'No port selected.'
        : this.inbound.has(this.port) ? `waiting for the arbitration of ${this.port}…`
          : `${this.port} has no connections in: nothing to arbitrate.`);
      return;
    }
    this.renderConnections();
  }

  renderConnections() {
    const cur = this.latest();
    if (!cur) return;
    const doc = this.docs.get(this.port);
    const byDoc = new Map(arr(doc && doc.connections).filter((c) => c && typeof c.source === 'string').map((c) => [c.source, c]));
    const live = arr(cur.p.connections).filter((c) => c && typeof c.source === 'string');
    const sources = live.map((c) => c.source);
    for (const s of byDoc.keys()) if (!sources.includes(s)) sources.push(s);
    const empty = this.e.list.querySelector('.empty');
    if (empty) empty.remove();
    for (const [s, row] of this.rows) if (!sources.includes(s)) { row.root.remove(); this.rows.delete(s); }
    sources.forEach((source, index) => {
      let row = this.rows.get(source);
      if (!row) { row = this.makeRow(source); this.rows.set(source, row); }
      if (this.e.list.children[index] !== row.root) this.e.list.insertBefore(row.root, this.e.list.children[index] || null);
      const c = live.find((x) => x.source === source) || {};
      const d = byDoc.get(source) || {};
      const prio = d.priority || {};
      const S = typeof c.S === 'number' ? c.S : prio.S;
      const x = typeof c.x === 'number' ? c.x : prio.x;
      const y = typeof c.y === 'number' ? c.y : prio.y;
      const winner = cur.p.winner === source;
      row.root.classList.toggle('is-winner', winner);
      setText(row.mark, winner ? 'WINNER' : d.aux ? 'aux' : '');
      const carrier = d.carrier || '';
      const scripts = carrierScripts(carrier);
      setText(row.carrier, carrier ? `${carrierKind(carrier)}${scripts.length ? ' · ' + scripts.join(', ') : ''}` : '');
      row.carrier.title = carrier;
      const constraint = 'constraint' in c ? c.constraint : d.constraint;
      const value = 'constraint_value' in c ? c.constraint_value : d.constraint_value;
      setText(row.constraint, typeof constraint === 'string' && constraint ? constraint : 'no constraint');
      setText(row.cvalue, value === false ? 'false' : 'true');
      row.cvalue.className = `cvalue ${value === false ? 'false' : 'true'}`;
      row.sbar.style.width = `${Math.max(0, Math.min(1, num(S))) * 100}%`;
      setText(row.s, fmtNum(S));
      setText(row.x, fmtNum(x, 0));
      setText(row.y, fmtNum(y));
      const k = d.counters || {};
      const parts = [`recv ${num(k.received)}`, `deliv ${num(k.delivered)}`];
      for (const [key, short] of [['dropped_by_accept', 'accept'], ['dropped_by_constraint', 'constraint'], ['dropped_by_priority', 'priority'], ['dropped_by_queue', 'queue']]) {
        if (num(k[key])) parts.push(`✕${short} ${num(k[key])}`);
      }
      if (num(k.script_errors)) parts.push(`script errors ${num(k.script_errors)}`);
      setText(row.counters, parts.join('  '));
    });
  }

  makeRow(source) {
    const colour = colourOf(this.port, source);
    const r = {};
    r.mark = el('span', { class: 'mark' });
    r.carrier = el('span', { class: 'carrier' });
    r.constraint = el('code', { class: 'constraint' });
    r.cvalue = el('span', { class: 'cvalue' });
    r.sbar = el('span', { class: 'sbar-fill', style: { background: colour } });
    r.s = el('span', { class: 'val' }); r.x = el('span', { class: 'val' }); r.y = el('span', { class: 'val' });
    r.counters = el('div', { class: 'counters' });
    r.root = el('div', { class: 'conn', 'data-source': source, style: { borderLeftColor: colour } },
      el('div', { class: 'conn-head' },
        el('span', { class: 'swatch', style: { background: colour } }),
        el('span', { class: 'source', text: source }), r.mark, r.carrier),
      el('div', { class: 'conn-body' },
        el('span', { class: 'clabel', text: 'if' }), r.constraint, r.cvalue,
        el('span', { class: 'sxy' },
          el('span', { class: 'k', text: 'S' }), el('span', { class: 'sbar' }, r.sbar), r.s,
          el('span', { class: 'k', text: 'x' }), r.x, el('span', { class: 'k', text: 'y' }), r.y)),
      r.counters);
    return r;
  }

  // Event container: time left counts down smoothly between snapshots.
  renderEvents() {
    const cur = this.latest();
    const events = cur ? arr(cur.p.events).filter((e) => e && typeof e.name === 'string') : [];
    const elapsed = cur && typeof cur.recv === 'number' ? (performance.now() - cur.recv) / 1000 : 0;
    const seen = new Set();
    if (events.length === 0) {
      if (!this.e.events.querySelector('.empty')) {
        this.e.events.replaceChildren(el('div', { class: 'empty', text: 'no events set' }));
        this.eventRows.clear();
      }
      return;
    }
    const empty = this.e.events.querySelector('.empty');
    if (empty) empty.remove();
    for (const ev of events) {
      const key = `${ev.name}\u0000${ev.owner}`;
      seen.add(key);
      let r = this.eventRows.get(key);
      if (!r) {
        r = { fill: el('span', { class: 'tl-fill' }), left: el('span', { class: 'tl-text' }) };
        const owner = typeof ev.owner === 'string' ? ev.owner : '';
        r.root = el('div', { class: 'event', title: `${ev.name} set by ${owner}` },
          el('span', { class: 'ev-name', text: ev.name }),
          el('span', { class: 'tl' }, r.fill), r.left,
          el('span', { class: 'ev-owner', text: owner ? `by ${owner}` : '' }));
        this.eventRows.set(key, r);
        this.e.events.append(r.root);
        r.max = 0;
      }
      if (typeof ev.time_left === 'number') {
        const left = Math.max(0, ev.time_left - elapsed);
        r.max = Math.max(r.max, ev.time_left);
        r.fill.style.width = `${r.max > 0 ? (left / r.max) * 100 : 0}%`;
        setText(r.left, `${left.toFixed(2)} s`);
      } else {
        r.fill.style.width = '100%';
        setText(r.left, 'no lifetime');
      }
    }
    for (const [k, r] of this.eventRows) if (!seen.has(k)) { r.root.remove(); this.eventRows.delete(k); }
  }

  tick() {
    if (!this.port) return;
    this.renderEvents();
    if (this.dirty) {
      this.dirty = false;
      this.render();
      this.updatePlot();
    }
  }

  // ---- the plot ----
  rebuildPlot() {
    if (this.plot) { this.plot.destroy(); this.plot = null; }
    const h = this.history.ports.get(this.port);
    const sources = h ? h.sources.slice() : [];
    this.plotKey = `${this.port}|${sources.join('|')}`;
    if (!sources.length) {
      this.e.plot.replaceChildren(el('div', { class: 'empty', text: this.port && this.inbound.has(this.port) ? 'waiting for arbitration data…' : '' }));
      return;
    }
    this.e.plot.replaceChildren();
    const series = [{}];
    for (const s of sources) {
      const colour = colourOf(this.port, s);
      series.push({ label: `S ${s}`, stroke: colour, width: 2.2, points: { show: false } });
      series.push({ label: `y ${s}`, stroke: colour, width: 1.4, dash: [6, 4], points: { show: false } });
      series.push({ label: `x ${s}`, stroke: colour + '99', width: 1, points: { show: false },
        paths: window.uPlot.paths.stepped({ align: 1 }) });
    }
    this.sources = sources;
    const self = this;
    const axis = { stroke: '#8fa3b8', grid: { stroke: '#243142', width: 1 }, ticks: { stroke: '#2c3a4c', width: 1 }, font: '11px system-ui, sans-serif' };
    const rect = this.e.plot.getBoundingClientRect();
    this.plot = new window.uPlot({
      width: Math.max(200, Math.floor(rect.width)), height: Math.max(120, Math.floor(rect.height)),
      legend: { show: false },
      cursor: { drag: { x: false, y: false }, points: { show: false } },
      scales: {
        x: { time: false, range: () => [-WINDOW_S, 0] },
        y: { range: () => [self.yMin(), 1.08] },
      },
      axes: [
        { ...axis, values: (u, splits) => splits.map((v) => (v === 0 ? 'now' : `${v} s`)), incrs: [5, 10, 15, 30] },
        { ...axis, splits: () => [0, 0.5, 1], values: (u, splits) => splits.map((v) => v.toFixed(1)), size: 36 },
      ],
      series,
      hooks: { draw: [(u) => self.drawBands(u)] },
    }, this.plotData(), this.e.plot);
  }

  lanes() {
    const h = this.history.ports.get(this.port);
    const names = [];
    if (h) for (const s of h.samples) for (const n of s.events) if (!names.includes(n)) names.push(n);
    return names.sort();
  }

  yMin() { return -(0.3 + 0.17 * (this.laneNames ? this.laneNames.length : 0)); }

  plotData() {
    const h = this.history.ports.get(this.port);
    const xs = [];
    const cols = this.sources ? this.sources.map(() => [[], [], []]) : [];
    if (h && h.samples.length) {
      const now = h.latestT;
      for (const s of h.samples) {
        if (s.t < now - WINDOW_S - 1) continue;
        xs.push(s.t - now);
        (this.sources || []).forEach((src, i) => {
          const c = s.conns.get(src);
          cols[i][0].push(c ? c.S : null); cols[i][1].push(c ? c.y : null); cols[i][2].push(c ? c.x : null);
        });
      }
    }
    return [xs, ...cols.flat()];
  }

  updatePlot() {
    const h = this.history.ports.get(this.port);
    const key = `${this.port}|${h ? h.sources.join('|') : ''}`;
    const lanes = this.lanes();
    const lanesChanged = !this.laneNames || lanes.join('|') !== this.laneNames.join('|');
    this.laneNames = lanes;
    if (key !== this.plotKey || !this.plot) { this.rebuildPlot(); return; }
    if (lanesChanged) this.plot.setScale('y', { min: this.yMin(), max: 1.08 });
    this.plot.setData(this.plotData());
  }

  resizePlot() {
    if (!this.plot) return;
    const rect = this.e.plot.getBoundingClientRect();
    const w = Math.max(200, Math.floor(rect.width)); const hgt = Math.max(120, Math.floor(rect.height));
    if (w !== this.plot.width || hgt !== this.plot.height) this.plot.setSize({ width: w, height: hgt });
  }

  // Under y = 0: the winner band, then one lane per event of the container (set = filled).
  drawBands(u) {
    const h = this.history.ports.get(this.port);
    if (!h || !h.samples.length) return;
    const ctx = u.ctx;
    const now = h.latestT;
    const dpr = window.devicePixelRatio || 1;
    const left = u.bbox.left; const right = u.bbox.left + u.bbox.width;
    const X = (t) => Math.max(left, Math.min(right, u.valToPos(t - now, 'x', true)));
    const Y = (v) => u.valToPos(v, 'y', true);
    const runs = (value) => {
      // [start t, end t, value] for consecutive samples of the same value
      const out = [];
      let start = null; let cur;
      h.samples.forEach((s, i) => {
        const v = value(s);
        if (start === null) { start = s.t; cur = v; return; }
        if (v !== cur) { out.push([start, s.t, cur]); start = s.t; cur = v; }
        if (i === h.samples.length - 1) out.push([start, s.t, cur]);
      });
      if (h.samples.length === 1) out.push([start, start + 0.05, cur]);
      return out;
    };
    ctx.save();
    ctx.font = `${11 * dpr}px system-ui, sans-serif`;
    ctx.textBaseline = 'middle';
    ctx.textAlign = 'left';
    const band = (top, bottom, label, pieces, colour) => {
      const y0 = Y(top); const y1 = Y(bottom);
      ctx.fillStyle = '#121a23';
      ctx.fillRect(left, y0, right - left, y1 - y0);
      for (const [a, b, v] of pieces) {
        if (v === null || v === false) continue;
        ctx.fillStyle = colour(v);
        const xa = X(a); const xb = X(b);
        if (xb > xa) ctx.fillRect(xa, y0, Math.max(1, xb - xa), y1 - y0);
        if (typeof v === 'string' && xb - xa > 170 * dpr) {
          ctx.fillStyle = '#0b1016';
          ctx.fillText(v, xa + 6 * dpr, (y0 + y1) / 2);
        }
      }
      // the lane's name, inside it at the left, on a dark pill so that it stays legible
      const w = ctx.measureText(label).width + 10 * dpr;
      ctx.fillStyle = 'rgba(11, 16, 22, 0.85)';
      ctx.fillRect(left + 2 * dpr, y0 + 1 * dpr, w, y1 - y0 - 2 * dpr);
      ctx.fillStyle = '#c9d4e0';
      ctx.fillText(label, left + 7 * dpr, (y0 + y1) / 2);
    };
    band(-0.06, -0.24, 'winner', runs((s) => s.winner), (v) => colourOf(this.port, v));
    (this.laneNames || []).forEach((name, i) => {
      const top = -0.3 - 0.17 * i;
      band(top - 0.02, top - 0.14, name, runs((s) => s.events.includes(name)), () => '#8b9bb0');
    });
    ctx.restore();
  }
}
