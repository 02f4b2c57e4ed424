// The timeline under the 3D view: per speaker a lane of words, a lane of pose controls (green;
// a tick where the stroke plays) and a lane of style controls and pauses (red, grey), on the
// performance clock, with a playhead. A click on a word jumps to its start, on a pose control to
// its stroke, on a style control to its start, anywhere else to that time. The playhead stays in
// view whenever the time moves (playing, a jump, a scrub, paused or not); a redraw at the same
// time leaves the scroll where the user put it.

const LABEL_PX = 86;
const MIN_PPS = 110; // pixels per second at least: a short word stays readable (a longer take scrolls)

export class Timeline {
  constructor(root, seek) {
    this.root = root;
    this.seek = seek;
    this.pps = 100; // pixels per second
    this.zoom = 1;
    this.duration = 0;
    this.time = 0;
    this.spoken = new Set();
    this.words = [];
    this.inner = document.createElement('div');
    this.inner.className = 'tl-inner';
    this.playhead = document.createElement('div');
    this.playhead.className = 'tl-playhead';
    root.replaceChildren(this.inner);
    root.addEventListener('click', (e) => {
      const item = e.target.closest('[data-seek]');
      if (item) {
        this.seek(parseFloat(item.dataset.seek));
        return;
      }
      const box = this.inner.getBoundingClientRect();
      const x = e.clientX - box.left - LABEL_PX;
      if (x >= 0) this.seek(x / this.pps);
    });
  }

  // Lay out a take's words and controls.
  show(take) {
    this.take = take;
    this.duration = take.duration;
    this.layout();
  }

  layout() {
    const take = this.take;
    if (!take) return;
    const width = Math.max(200, this.root.clientWidth - LABEL_PX - 4);
    const fit = width / Math.max(take.duration, 0.1);
    this.minZoom = Math.min(1, fit / Math.max(fit, MIN_PPS)); // zoomed out as far as the whole take
    this.zoom = Math.max(this.minZoom, this.zoom);
    this.pps = Math.max(fit, MIN_PPS) * this.zoom;
    const x = (t) => `${(t * this.pps).toFixed(1)}px`;
    this.inner.replaceChildren();
    this.inner.style.width = `${LABEL_PX + take.duration * this.pps + 4}px`;
    const ruler = this._lane('', 'tl-ruler');
    const step = this.pps >= 80 ? 1 : this.pps >= 30 ? 2 : 5;
    for (let t = 0; t <= take.duration + 1e-6; t += step) {
      const tick = document.createElement('span');
      tick.className = 'tl-tick';
      tick.style.left = x(t);
      tick.textContent = `${t.toFixed(0)}s`;
      ruler.append(tick);
    }
    this.words = [];
    let rows = 1;
    for (const speaker of take.speakers) {
      const name = speaker.name;
      const words = this._lane(name, 'tl-words');
      rows += 1;
      take.words.filter((wd) => wd.speaker === name).forEach((wd) => {
        const el = this._item(words, 'tl-word', wd.start, wd.end, wd.word, wd.start, `${wd.word} · ${wd.start.toFixed(2)}-${wd.end.toFixed(2)} s`);
        this.words.push([wd, el]);
      });
      const own = take.controls.filter((k) => k.speaker === name);
      const poses = pack(own.filter((k) => k.kind === 'pose'));
      const styles = pack(own.filter((k) => k.kind !== 'pose'));
      (poses.length ? poses : [[]]).forEach((row, r) => {
        const lane = this._lane(r === 0 ? 'pose' : '', 'tl-poses');
        rows += 1;
        for (const c of row) {
          const el = this._item(lane, 'tl-pose', c.start, c.end, c.label, c.stroke ?? c.start,
            `[pose:${c.label}] line ${c.line}` + (c.stroke != null ? ` · stroke ${c.stroke.toFixed(2)} s (frame ${c.stroke_frame})` : ''));
          el.dataset.name = c.name;
          el.dataset.strokeFrame = c.stroke_frame ?? '';
          if (c.stroke != null) {
            const tick = document.createElement('span');
            tick.className = 'tl-stroke';
            tick.style.left = `${((c.stroke - c.start) * this.pps).toFixed(1)}px`;
            el.append(tick);
          }
        }
      });
      styles.forEach((row, r) => {
        const lane = this._lane(r === 0 ? 'style' : '', 'tl-styles');
        rows += 1;
        for (const c of row) {
          this._item(lane, c.kind === 'pause' ? 'tl-pause' : 'tl-style', c.start, c.end, c.label, c.start, `${c.label} · line ${c.line}`);
        }
      });
    }
    this.root.style.height = `${Math.min(rows * 22 + 14, Math.round(window.innerHeight * 0.4))}px`;
    this.inner.append(this.playhead);
    this._place(true); // zoomed or resized: the playhead where it is now, in view
  }

  _lane(label, cls) {
    const row = document.createElement('div');
    row.className = `tl-row ${cls}`;
    const name = document.createElement('div');
    name.className = 'tl-label';
    name.textContent = label;
    const items = document.createElement('div');
    items.className = 'tl-items';
    row.append(name, items);
    this.inner.append(row);
    return items;
  }

  _item(lane, cls, start, end, text, seekTo, title) {
    const el = document.createElement('div');
    el.className = `tl-item ${cls}`;
    el.style.left = `${(start * this.pps).toFixed(1)}px`;
    el.style.width = `${Math.max(2, (end - start) * this.pps).toFixed(1)}px`;
    el.textContent = text;
    el.title = title;
    el.dataset.seek = String(seekTo);
    lane.append(el);
    return el;
  }

  // Move the playhead to `t` and mark the words being spoken (`spoken`, a Set of the take's words);
  // a time that moved brings the playhead into view.
  update(t, spoken) {
    const moved = t !== this.time;
    this.time = t;
    this.spoken = spoken;
    this._place(moved);
  }

  _place(follow) {
    const left = LABEL_PX + this.time * this.pps;
    this.playhead.style.left = `${left.toFixed(1)}px`;
    for (const [wd, el] of this.words) el.classList.toggle('now', this.spoken.has(wd));
    const view = this.root;
    if (follow && (left < view.scrollLeft + LABEL_PX || left > view.scrollLeft + view.clientWidth - 40)) {
      view.scrollLeft = Math.max(0, left - LABEL_PX - 40);
    }
  }

  setZoom(z) {
    this.zoom = Math.max(this.minZoom || 1, Math.min(32, z));
    this.layout();
  }
}

// Controls in rows where none overlaps another (the first row that has room).
function pack(controls) {
  const rows = [];
  for (const c of [...controls].sort((a, b) => a.start - b.start)) {
    const row = rows.find((r) => r[r.length - 1].end <= c.start + 1e-6);
    if (row) row.push(c); else rows.push([c]);
  }
  return rows;
}
