// Plexus web page: the live system graph, the arbitration of a port, its last messages.
// Served by plexusd --http (docs/WEB.md); talks to the same origin only: /api/system,
// /api/stream (EventSource), /api/messages?port=P. No build step; libraries in vendor/.
//
// Stable hooks for tests (tests/web/page_test.py relies on them; keep them):
//   #graph                              the system graph's container (cytoscape)
//   [data-testid="connection-list"]     the selected port's connections, one child element each
//                                       with data-source="/demo/face/out" (its source port)
//   [data-testid="winner"]              text: the winner's source port, or "none"
//   [data-testid="plot"]                the stimulation plot (uPlot) of the selected port
//   [data-testid="events"]              the selected port's event container
//   [data-testid="messages"]            the selected port's last messages
//   [data-testid="status"]              the status line; [data-testid="disconnected"] the badge
//                                       (hidden while the stream is connected)
//   window.plexusPage.selectedPort      the selected port's name (string, "" before any)
//   window.plexusPage.plotPoints()      {source: number of 20 Hz points received in the last 10 s}
//                                       for the selected port
//   window.plexusPage.select(port)      select a port as a click in the graph does
//   window.plexusPage.graph()           {ports: [names drawn], edges: ["/a/out->/b/in", ...]}
//   window.plexusPage.errors            count of exceptions caught in event handlers (normally 0)

import { Graph } from './graph.js';
import { History, ArbitrationPanel } from './arbitration.js';
import { Messages } from './messages.js';
import { el, setText, colourOf, arr } from './util.js';

const STALL_MS = 3000;         // no stream event for this long: show the badge
const RETRY_MS = 2000;         // reopen a stream the browser gave up on

const history = new History();
const panel = new ArbitrationPanel(history);
const messages = new Messages();
const graph = new Graph(document.getElementById('graph'), (port) => select(port, true));

const state = {
  selected: '',
  system: null,
  localNode: '',
  portNodes: new Map(),       // port -> node name
  arbitratedOrder: [],        // arbitrated ports, in the order the system lists them
  winners: new Map(),         // arbitrated port -> winner source (or null)
  es: null,
  esMessages: null,           // the port whose messages the open stream carries
  lastEvent: 0,
  eventTimes: [],
  connected: false,
  errors: 0,
};

window.plexusPage = {
  get selectedPort() { return state.selected; },
  plotPoints() { return history.points(state.selected, 10); },
  select(port) { select(port, true); },
  graph() {
    return {
      ports: graph.cy.nodes('.port').map((n) => n.data('port')),
      edges: graph.cy.edges().map((e) => e.id().slice(2)),
    };
  },
  get errors() { return state.errors; },
};

function guard(fn) {
  return (...a) => {
    try { return fn(...a); } catch (e) {
      // never let one bad document break the page; keep it visible for whoever debugs it
      state.errors++;
      console.warn('plexus page:', e);
      return undefined;
    }
  };
}

function parse(ev) {
  try { return JSON.parse(ev.data); } catch { return null; }
}

// ---- the system document (1 Hz) ----
function onSystem(sys) {
  if (!sys || typeof sys !== 'object') return;
  state.system = sys;
  state.localNode = typeof sys.node === 'string' ? sys.node : '';
  const docs = new Map();
  const order = [];
  const recv = performance.now();
  for (const n of arr(sys.nodes)) {
    for (const a of arr(n && n.arbitration)) {
      if (!a || typeof a.port !== 'string') continue;
      a._recv = recv;
      docs.set(a.port, a);
      order.push(a.port);
      if (!state.winners.has(a.port) || !history.ports.has(a.port)) state.winners.set(a.port, a.winner ?? null);
    }
  }
  const { ports, arbitrated } = graph.update(sys, state.winners);
  state.portNodes = new Map([...ports].map(([name, p]) => [name, p.node]));
  for (const p of arbitrated) if (!order.includes(p)) order.push(p);
  state.arbitratedOrder = order;
  panel.setDocs(docs, arbitrated);
  renderPortList();
  if (!state.selected && order.length) select(fromHash() || order[0], false);
  else if (!state.selected && ports.size) select(fromHash() || [...ports.keys()][0], false);
  else if (state.selected) panel.changed();
  renderStatus();
}

// ---- the arbitration snapshots (20 Hz) ----
let winnersChanged = false;
function onArbitration(a) {
  if (!a || typeof a.t !== 'number') return;
  const recv = performance.now();
  for (const p of arr(a.ports)) {
    if (!p || typeof p.port !== 'string') continue;
    history.add(a.t, p, recv);
    const w = typeof p.winner === 'string' ? p.winner : null;
    if (state.winners.get(p.port) !== w) { state.winners.set(p.port, w); winnersChanged = true; }
    if (!state.arbitratedOrder.includes(p.port)) { state.arbitratedOrder.push(p.port); winnersChanged = true; }
  }
  if (winnersChanged) {
    winnersChanged = false;
    renderPortList();
    if (state.system) graph.update(state.system, state.winners);
  }
  if (!state.selected && state.arbitratedOrder.length) select(state.arbitratedOrder[0], false);
  panel.changed();
}

// ---- event container changes: the 20 Hz snapshots carry the container; redraw at once ----
function onEventChange(e) {
  if (e && e.port === state.selected) panel.changed();
}

// ---- selection ----
function fromHash() {
  const h = decodeURIComponent(location.hash.slice(1));
  return h.startsWith('/') && state.portNodes.has(h) ? h : '';
}

function isLocal(port) {
  return !!port && state.portNodes.get(port) === state.localNode && state.localNode !== '';
}

function select(port, byUser) {
  if (typeof port !== 'string' || !port) return;
  if (port !== state.selected) {
    state.selected = port;
    graph.select(port);
    panel.select(port);
    const local = isLocal(port);
    messages.select(port, local ? '' : `${port} is on daemon ${state.portNodes.get(port) || '?'}: its messages are shown by that daemon's page`);
    if (local) loadMessages(port);
    renderPortList();
    if (byUser) history_replace(port);
  }
  const want = isLocal(port) ? port : null;
  if (state.esMessages !== want || !state.es) openStream(want);
}

function history_replace(port) {
  try { window.history.replaceState(null, '', `#${encodeURIComponent(port)}`); } catch { /* file:// */ }
}

async function loadMessages(port) {
  try {
    const r = await fetch(`/api/messages?port=${encodeURIComponent(port)}`, { headers: { Accept: 'application/json' } });
    if (!r.ok) return;
    const doc = await r.json();
    if (port === state.selected && doc) messages.add(doc.messages);
  } catch { /* the stream brings them too */ }
}

function renderPortList() {
  const list = document.getElementById('port-list');
  const ports = state.arbitratedOrder.slice();
  if (state.selected && !ports.includes(state.selected)) ports.push(state.selected);
  const key = ports.map((p) => `${p}|${p === state.selected}|${state.winners.get(p)}`).join('\n');
  if (list.dataset.key === key) return;
  list.dataset.key = key;
  list.replaceChildren(...ports.map((p) => {
    const w = state.winners.get(p);
    return el('button', { class: `port-chip${p === state.selected ? ' selected' : ''}`, 'data-port': p, title: w ? `winner: ${w}` : 'no winner', onclick: () => select(p, true) },
      el('span', { class: 'dot', style: { background: w ? colourOf(p, w) : '#3b4a5c' } }), p);
  }));
}

// ---- the stream ----
function openStream(messagesPort) {
  if (state.es) state.es.close();
  state.esMessages = messagesPort;
  const url = messagesPort ? `/api/stream?messages=${encodeURIComponent(messagesPort)}` : '/api/stream';
  const es = new EventSource(url);
  state.es = es;
  const seen = () => {
    state.lastEvent = performance.now();
    state.eventTimes.push(state.lastEvent);
    if (!state.connected) { state.connected = true; renderStatus(); }
  };
  es.addEventListener('open', guard(() => { if (es === state.es) { state.connected = true; renderStatus(); } }));
  es.addEventListener('system', guard((ev) => { if (es !== state.es) return; seen(); onSystem(parse(ev)); }));
  es.addEventListener('arbitration', guard((ev) => { if (es !== state.es) return; seen(); onArbitration(parse(ev)); }));
  es.addEventListener('event', guard((ev) => { if (es !== state.es) return; seen(); onEventChange(parse(ev)); }));
  es.addEventListener('message', guard((ev) => {
    if (es !== state.es) return;
    seen();
    const m = parse(ev);
    if (m && state.esMessages === state.selected) messages.add([m]);
  }));
  es.addEventListener('error', guard(() => {
    if (es !== state.es) return;
    state.connected = false;
    state.failed = true;
    renderStatus();
    // The browser retries by itself while CONNECTING; once CLOSED (an HTTP error) it gives up.
    if (es.readyState === EventSource.CLOSED) {
      setTimeout(() => { if (es === state.es) openStream(state.esMessages); }, RETRY_MS);
    }
  }));
}

// ---- status line ----
function renderStatus() {
  const now = performance.now();
  while (state.eventTimes.length && state.eventTimes[0] < now - 2000) state.eventTimes.shift();
  const rate = state.eventTimes.length / 2;
  const stalled = state.connected && state.lastEvent && now - state.lastEvent > STALL_MS;
  const down = !state.connected || stalled;
  const badge = document.getElementById('badge');
  // not while the first connection is still being made: only once it failed or went quiet
  badge.hidden = !(stalled || (!state.connected && (state.lastEvent || state.failed)));
  setText(badge, stalled ? 'no data' : 'disconnected');
  const sys = state.system;
  const parts = [];
  if (sys) {
    const nodes = arr(sys.nodes);
    const bad = nodes.filter((n) => n && n.error).length;
    parts.push(`node ${state.localNode || '?'} answering`);
    parts.push(`${nodes.length} daemon${nodes.length === 1 ? '' : 's'}${bad ? ` (${bad} not answering)` : ''}`);
    const nports = state.portNodes.size;
    parts.push(`${nports} port${nports === 1 ? '' : 's'}`);
    if (sys.names && sys.names.error) parts.push(`name server: ${sys.names.error}`);
  } else {
    parts.push('waiting for the daemon…');
  }
  parts.push(`stream ${rate.toFixed(1)} ev/s`);
  setText(document.getElementById('status'), parts.join('  ·  '));
  document.body.classList.toggle('offline', down && !!state.lastEvent);
}
setInterval(guard(renderStatus), 500);

// ---- start: the system first (to pick the port whose messages the stream carries), then the stream
(async () => {
  try {
    const r = await fetch('/api/system', { headers: { Accept: 'application/json' } });
    if (r.ok) guard(onSystem)(await r.json());
  } catch { /* the stream's first event is the same document */ }
  if (!state.es) openStream(isLocal(state.selected) ? state.selected : null);
  renderStatus();
})();

