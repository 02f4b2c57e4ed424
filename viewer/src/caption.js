// The word being spoken at a frame, by sgt render's rule (renders/overlay.py, frame_word): the word
// whose span holds the frame's middle, start <= (frame + 0.5) / fps < end (the first of them when
// two do), none between words. The page's document gives the words' times as sgt has them, not
// rounded (sgt_tui/view/page.py), so the page and sgt render caption every frame alike
// (tests/test_view_browser.py compares them frame by frame).

export function frameWord(words, frame, fps) {
  const t = (frame + 0.5) / fps;
  for (const w of words) if (w.start <= t && t < w.end) return w;
  return null;
}

// Each figure's words, in the take's order of speakers: a speaker's own (a take of one figure,
// a motion file from before the performance clock: all of them, as sgt render captions it).
export function wordsOfFigures(take) {
  if (take.speakers.length === 1) return [take.words];
  return take.speakers.map((s) => take.words.filter((w) => w.speaker === s.name));
}

// The words spoken at `frame`, one per figure that speaks then (in the take's order of speakers).
export function spokenAt(figureWords, frame, fps) {
  return figureWords.map((words) => frameWord(words, frame, fps)).filter((w) => w !== null);
}
