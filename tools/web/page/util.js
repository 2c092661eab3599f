// Small helpers shared by the page's modules.

export const PALETTE = ['#4cc9f0', '#f9a03f', '#b388ff', '#7bd389', '#ff6b9a', '#ffd166', '#5eead4', '#f87171'];

// Colour of a connection into a port: stable for the life of the page (by first sight).
const colours = new Map();
export function colourOf(port, source) {
  let m = colours.get(port);
  if (!m) { m = new Map(); colours.set(port, m); }
  if (!m.has(source)) m.set(source, PALETTE[m.size % PALETTE.length]);
  return m.get(source);
}

// `el('div', {class: 'x', 'data-source': s}, child, 'text', ...)`
export function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  if (attrs) {
    for (const [k, v] of Object.entries(attrs)) {
      if (v === undefined || v === null || v === false) continue;
      if (k === 'text') e.textContent = v;
      else if (k === 'style' && typeof v === 'object') Object.assign(e.style, v);
      else if (k.startsWith('on') && typeof v === 'function') e.addEventListener(k.slice(2), v);
      else e.setAttribute(k, v === true ? '' : String(v));
    }
  }
  for (const c of children) {
    if (c === undefined || c === null || c === false) continue;
    e.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return e;
}

// Set text only when it changed (avoids layout work at 20 Hz).
export function setText(e, text) {
  if (e && e.textContent !== text) e.textContent = text;
}

// The carrier kind: the first part of the carrier string ("tcp+recv.portmonitor+..." -> "tcp").
export function carrierKind(carrier) {
  if (typeof carrier !== 'string' || carrier === '') return '?';
  return carrier.split('+')[0];
}

// Monitor script names in a carrier string: every `file.NAME` part.
export function carrierScripts(carrier) {
  if (typeof carrier !== 'string') return [];
  const out = [];
  for (const part of carrier.split('+')) {
    if (part.startsWith('file.') && part.length > 5) out.push(part.slice(5));
  }
  return out;
}

export function fmtBytes(n) {
  if (typeof n !== 'number' || !isFinite(n)) return '?';
  if (n < 1024) return `${n} B`;
  if (n < 1024 * 1024) return `${(n / 1024).toFixed(1)} KiB`;
  if (n < 1024 * 1024 * 1024) return `${(n / 1024 / 1024).toFixed(1)} MiB`;
  return `${(n / 1024 / 1024 / 1024).toFixed(2)} GiB`;
}

export function fmtNum(v, digits = 2) {
  return typeof v === 'number' && isFinite(v) ? v.toFixed(digits) : '–';
}

export function fmtClock(t) {
  if (typeof t !== 'number') return '';
  const d = new Date(t * 1000);
  const p = (n, w = 2) => String(n).padStart(w, '0');
  return `${p(d.getHours())}:${p(d.getMinutes())}:${p(d.getSeconds())}.${p(d.getMilliseconds(), 3)}`;
}

export const num = (v) => (typeof v === 'number' && isFinite(v) ? v : 0);
export const arr = (v) => (Array.isArray(v) ? v : []);
