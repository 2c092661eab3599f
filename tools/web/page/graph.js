// The system graph: daemons as compound nodes, their ports inside, connections as edges.
// Laid out (dagre, left to right) only when the structure changes, so live updates never jump.

import { arr, num, carrierKind, carrierScripts, colourOf } from './util.js';

const RECENT_S = 5;          // a counter that grew in the last RECENT_S seconds "is dropping now"

// Counters that mean data filtered on purpose (monitor refused, constraint false, lost the
// arbitration) versus data lost (queue full, monitor backlog): orange versus red.
const FILTER_COUNTERS = ['dropped_by_accept', 'dropped_by_constraint', 'dropped_by_priority', 'dropped_by_monitor'];
const LOSS_COUNTERS = ['dropped_by_queue', 'dropped_monitor_backlog', 'dropped_queue'];

const STYLE = [
  { selector: 'node', style: {
    'font-family': 'system-ui, sans-serif', 'color': '#d8e0ea', 'font-size': 12,
  } },
  { selector: 'node.daemon', style: {
    'shape': 'round-rectangle', 'background-color': '#18212c', 'background-opacity': 1,
    'border-color': '#33465c', 'border-width': 1.5, 'padding': 16,
    'label': 'data(label)', 'text-valign': 'top', 'text-halign': 'center', 'text-margin-y': -4,
    'font-size': 12, 'color': '#8fa3b8', 'font-weight': 600,
  } },
  { selector: 'node.daemon.unreachable', style: { 'border-color': '#f87171', 'border-style': 'dashed' } },
  { selector: 'node.port', style: {
    'shape': 'round-rectangle', 'width': 'data(w)', 'height': 'data(h)',
    'background-color': '#223041', 'border-color': '#4a5d75', 'border-width': 1.5,
    'label': 'data(label)', 'text-valign': 'center', 'text-halign': 'center', 'text-wrap': 'wrap',
    'font-size': 13, 'color': '#e6edf5', 'line-height': 1.3,
  } },
  { selector: 'node.port.arbitrated', style: { 'border-color': '#7aa7d6', 'border-width': 2 } },
  { selector: 'node.port.filtering', style: { 'border-color': '#f9a03f', 'border-width': 2.5 } },
  { selector: 'node.port.losing', style: { 'border-color': '#f87171', 'border-width': 3, 'background-color': '#3a1f24' } },
  { selector: 'node.port.selected', style: {
    'border-color': '#4cc9f0', 'border-width': 3, 'background-color': '#1d3a4d',
    'underlay-color': '#4cc9f0', 'underlay-opacity': 0.18, 'underlay-padding': 6,
  } },
  { selector: 'edge', style: {
    'curve-style': 'bezier', 'target-arrow-shape': 'triangle', 'arrow-scale': 1.1,
    'width': 2, 'line-color': '#5c7088', 'target-arrow-color': '#5c7088',
    'label': 'data(label)', 'text-wrap': 'wrap', 'font-size': 12, 'color': '#c9d4e0',
    'font-family': 'system-ui, sans-serif',
    'text-background-color': '#0f1419', 'text-background-opacity': 0.85, 'text-background-padding': 3,
    'text-background-shape': 'round-rectangle',
  } },
  { selector: 'edge[colour]', style: { 'line-color': 'data(colour)', 'target-arrow-color': 'data(colour)' } },
  { selector: 'edge.winner', style: { 'width': 5 } },
  { selector: 'edge.notlive', style: { 'line-style': 'dashed', 'opacity': 0.6 } },
  { selector: 'edge.filtering', style: { 'color': '#f9b45f' } },
  { selector: 'edge.losing', style: { 'color': '#fb8f8f', 'line-color': '#f87171', 'target-arrow-color': '#f87171', 'line-style': 'dashed' } },
  { selector: 'edge.quarantined', style: { 'color': '#fb8f8f', 'line-color': '#f87171', 'target-arrow-color': '#f87171', 'line-style': 'dotted', 'width': 4 } },
];

export class Graph {
  constructor(container, onSelect) {
    this.onSelect = onSelect;
    this.structure = '';
    this.history = new Map();   // counter key -> {value, changedAt}
    this.selected = null;
    this.cy = window.cytoscape({
      container, style: STYLE, elements: [],
      minZoom: 0.3, maxZoom: 2.5,
      boxSelectionEnabled: false, autoungrabify: false,
    });
    this.cy.on('tap', 'node.port', (ev) => this.onSelect(ev.target.data('port')));
    this.cy.on('tap', 'edge', (ev) => this.onSelect(ev.target.data('destination')));
    let pending = 0;
    window.addEventListener('resize', () => {
      clearTimeout(pending);
      pending = setTimeout(() => { this.cy.resize(); this.cy.fit(undefined, 24); }, 150);
    });
  }

  // How much a counter grew recently: true while it increased in the last RECENT_S seconds.
  growing(key, value, now) {
    const h = this.history.get(key);
    if (!h) { this.history.set(key, { value, changedAt: -Infinity }); return false; }
    if (value > h.value) h.changedAt = now;
    h.value = value;
    return now - h.changedAt < RECENT_S;
  }

  // From a /api/system document: the elements and their live state.
  update(system, winners) {
    const now = performance.now() / 1000;
    const daemons = new Map();      // node name -> {address, error}
    const ports = new Map();        // port name -> {node, stats}
    const edges = new Map();        // "src->dst" -> {source, destination, carrier, live, inbound, outgoing}
    for (const n of arr(system && system.nodes)) {
      if (!n || typeof n.node !== 'string') continue;
      daemons.set(n.node, { address: n.address || '', error: n.error || null });
      const stats = n.stats && !n.stats.error ? n.stats : null;
      for (const p of arr(stats && stats.ports)) {
        if (!p || typeof p.name !== 'string') continue;
        ports.set(p.name, { node: n.node, stats: p });
        for (const o of arr(p.outgoing)) {
          const id = `${p.name}->${o.destination}`;
          const e = edges.get(id) || { source: p.name, destination: o.destination };
          e.carrier = e.carrier || o.carrier; e.outgoing = o; edges.set(id, e);
        }
        for (const i of arr(p.inbound)) {
          const id = `${i.source}->${p.name}`;
          const e = edges.get(id) || { source: i.source, destination: p.name };
          e.carrier = i.carrier || e.carrier; e.inbound = i; edges.set(id, e);
        }
      }
    }
    const names = system && system.names && !system.names.error ? system.names : null;
    for (const p of arr(names && names.ports)) {
      if (!p || typeof p.name !== 'string' || ports.has(p.name)) continue;
      if (!daemons.has(p.node)) daemons.set(p.node, { address: p.address || '', error: 'not asked' });
      ports.set(p.name, { node: p.node, stats: null });
    }
    for (const c of arr(names && names.connections)) {
      if (!c || typeof c.source !== 'string' || typeof c.destination !== 'string') continue;
      const id = `${c.source}->${c.destination}`;
      const e = edges.get(id) || { source: c.source, destination: c.destination };
      e.carrier = e.carrier || c.carrier; e.live = c.live; edges.set(id, e);
    }
    // A connection to or from a port nobody lists still needs its end drawn.
    for (const e of edges.values()) {
      for (const p of [e.source, e.destination]) {
        if (!ports.has(p)) ports.set(p, { node: '?', stats: null });
      }
    }
    if (ports.has('?') || [...ports.values()].some((p) => p.node === '?')) {
      daemons.set('?', { address: '', error: 'unknown daemon' });
    }

    const arbitrated = new Set([...edges.values()].map((e) => e.destination));
    const elements = [];
    for (const [name, d] of daemons) {
      elements.push({ group: 'nodes', data: { id: `d:${name}`, label: d.address ? `${name}  ${d.address}` : name },
        classes: d.error ? 'daemon unreachable' : 'daemon' });
    }
    for (const [name, p] of ports) {
      const s = p.stats;
      const lossKey = `${name}|dropped_queue`;
      const losing = s ? this.growing(lossKey, num(s.dropped_queue), now) : false;
      let label = name;
      if (s && (num(s.dropped_queue) > 0 || num(s.depth) > 0)) {
        label += `\nqueue ${num(s.depth)}/${num(s.capacity)}` + (num(s.dropped_queue) ? ` · lost ${num(s.dropped_queue)}` : '');
      }
      const lines = label.split('\n');
      const w = Math.max(...lines.map((l) => l.length)) * 7.8 + 22;
      const cls = ['port'];
      if (arbitrated.has(name)) cls.push('arbitrated');
      if (losing) cls.push('losing');
      if (name === this.selected) cls.push('selected');
      elements.push({ group: 'nodes', data: { id: `p:${name}`, parent: `d:${p.node}`, port: name, label, w, h: 18 + 17 * lines.length },
        classes: cls.join(' ') });
    }
    for (const [id, e] of edges) {
      const kind = carrierKind(e.carrier);
      const scripts = new Set(carrierScripts(e.carrier));
      let quarantined = false;
      let filtered = 0; let lost = 0; let filtering = false; let losing = false;
      const i = e.inbound || {};
      const o = e.outgoing || {};
      for (const m of arr(i.monitors)) {
        if (m && typeof m.script === 'string') scripts.add(m.script);
        if (m && m.quarantined) quarantined = true;
      }
      for (const k of FILTER_COUNTERS) {
        const v = num(k === 'dropped_by_monitor' ? o[k] : i[k]);
        filtered += v;
        if (this.growing(`${id}|${k}`, v, now)) filtering = true;
      }
      for (const k of LOSS_COUNTERS) {
        const v = num(i[k]);
        lost += v;
        if (this.growing(`${id}|${k}`, v, now)) losing = true;
      }
      let label = kind + (scripts.size ? ` · ${[...scripts].join(', ')}` : '');
      const drops = [];
      if (filtered) drops.push(`filtered ${filtered}`);
      if (lost) drops.push(`lost ${lost}`);
      if (quarantined) drops.push('QUARANTINED');
      if (drops.length) label += `\n${drops.join(' · ')}`;
      const cls = [];
      if (e.live === false) cls.push('notlive');
      if (quarantined) cls.push('quarantined');
      else if (losing) cls.push('losing');
      else if (filtering) cls.push('filtering');
      const w = winners.get(e.destination);
      if (w !== undefined && w === e.source) cls.push('winner');
      const data = { id: `e:${id}`, source: `p:${e.source}`, target: `p:${e.destination}`,
        destination: e.destination, label };
      if (w !== undefined) data.colour = colourOf(e.destination, e.source);
      elements.push({ group: 'edges', data, classes: cls.join(' ') });
    }
    // Port borders: a port whose inbound connections filter is orange.
    for (const el of elements) {
      if (el.group !== 'edges' || !el.classes.includes('filtering')) continue;
      const t = elements.find((x) => x.data.id === el.data.target);
      if (t && !t.classes.includes('losing') && !t.classes.includes('filtering')) t.classes += ' filtering';
    }
    this.apply(elements);
    return { ports, arbitrated, daemons };
  }

  apply(elements) {
    const structure = elements.map((e) => `${e.data.id}|${e.data.parent || ''}|${e.data.source || ''}|${e.data.target || ''}`).sort().join('\n');
    const cy = this.cy;
    if (structure === this.structure) {
      cy.batch(() => {
        for (const e of elements) {
          const c = cy.getElementById(e.data.id);
          if (c.empty()) continue;
          for (const [k, v] of Object.entries(e.data)) if (c.data(k) !== v) c.data(k, v);
          if (c.classes().join(' ') !== e.classes) c.classes(e.classes);
        }
      });
      return;
    }
    this.structure = structure;
    const firstTime = cy.elements().empty();
    cy.batch(() => {
      const keep = new Set(elements.map((e) => e.data.id));
      cy.elements().filter((c) => !keep.has(c.id())).remove();
      for (const e of elements) {
        const c = cy.getElementById(e.data.id);
        if (c.nonempty() && (c.data('parent') || '') === (e.data.parent || '')) {
          for (const [k, v] of Object.entries(e.data)) if (k !== 'source' && k !== 'target' && c.data(k) !== v) c.data(k, v);
          c.classes(e.classes);
        } else {
          if (c.nonempty()) c.remove();
          cy.add(e);
        }
      }
    });
    cy.layout({
      name: 'dagre', rankDir: 'LR', nodeSep: 34, rankSep: 170, edgeSep: 14, padding: 16,
      fit: true, animate: false,
    }).run();
    // a small system is not blown up to fill the panel
    if (cy.zoom() > 1.2) { cy.zoom(1.2); cy.center(); }
  }

  select(port) {
    this.selected = port;
    this.cy.batch(() => {
      this.cy.nodes('.port').forEach((n) => {
        if (n.data('port') === port) n.addClass('selected'); else n.removeClass('selected');
      });
    });
  }
}
