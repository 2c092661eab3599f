// A port's last messages: payload as JSON, blobs summarised by size.

import { el, fmtBytes, fmtClock, arr } from './util.js';

const KEEP = 20;

// The payload as compact JSON text, with {"blob": N, "type": "blob"} written as ‹blob 1.2 KiB›
// and {"truncated": N, "type": T} as ‹T of N bytes, truncated›.
export function payloadText(v, depth = 0) {
  if (v === null || typeof v !== 'object') return JSON.stringify(v) ?? 'null';
  if (depth > 8) return '…';
  if (!Array.isArray(v)) {
    const keys = Object.keys(v);
    if (v.type === 'blob' && typeof v.blob === 'number' && keys.length === 2) return `‹blob ${fmtBytes(v.blob)}›`;
    if (typeof v.truncated === 'number' && keys.length === 2) return `‹${v.type} of ${fmtBytes(v.truncated)}, truncated›`;
    return `{${keys.map((k) => `${JSON.stringify(k)}: ${payloadText(v[k], depth + 1)}`).join(', ')}}`;
  }
  return `[${v.map((x) => payloadText(x, depth + 1)).join(', ')}]`;
}

export class Messages {
  constructor() {
    this.list = document.getElementById('messages');
    this.title = document.getElementById('msg-port');
    this.port = null;
    this.items = [];
    this.lastSeq = null;
  }

  select(port, note) {
    this.port = port;
    this.items = [];
    this.title.textContent = port ? `of ${port}` : '';
    this.remote = note || '';
    this.render();
  }

  // Entries of /api/messages (newest last) or one `message` stream event.
  add(entries) {
    let added = false;
    for (const m of arr(entries)) {
      if (!m || typeof m !== 'object') continue;
      if (this.items.some((x) => x.seq === m.seq && x.t === m.t)) continue;
      this.items.push(m); added = true;
    }
    if (!added) return;
    this.items.sort((a, b) => (a.t || 0) - (b.t || 0));
    if (this.items.length > KEEP) this.items.splice(0, this.items.length - KEEP);
    this.render();
  }

  render() {
    if (!this.items.length) {
      this.list.replaceChildren(el('div', { class: 'empty', text: this.remote || (this.port ? 'no message seen yet' : 'select a port') }));
      return;
    }
    const rows = this.items.slice().reverse().map((m) => el('div', { class: 'msg' },
      el('span', { class: 'msg-meta' },
        el('span', { class: 'msg-t', text: fmtClock(m.t) }),
        el('span', { class: 'msg-seq', text: `#${m.seq ?? '?'}` }),
        el('span', { class: 'msg-size', text: fmtBytes(m.size) })),
      el('code', { class: 'msg-payload', text: payloadText(m.payload), title: payloadText(m.payload) })));
    this.list.replaceChildren(...rows);
  }
}
