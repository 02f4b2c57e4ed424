// The page's one clock: the performance's time in seconds. While the speech plays, its audio
// element is the clock (the WAV's sample 0 is motion frame 0, so its currentTime is the
// performance's time); without speech, or past its end, the clock runs on performance.now() at
// the playback speed. Seeking moves the audio with it, and the speed is the audio's rate.

export class Clock {
  constructor(audio) {
    this.audio = audio;
    this.duration = 0;
    this.speed = 1;
    this.playing = false;
    this.loop = false;
    this.hasAudio = false;
    this._at = 0; // the time at _since (performance.now(), ms) while the own clock runs
    this._since = 0;
    this.onend = null;
    audio.addEventListener('ended', () => {
      if (this.playing && this._ownTime() < this.duration - 0.05) this._anchor(this.audio.currentTime);
    });
  }

  setAudio(url) {
    this.hasAudio = !!url;
    if (url) {
      this.audio.src = url;
      this.audio.load();
    } else {
      this.audio.removeAttribute('src');
      this.audio.load();
    }
    this.audio.playbackRate = this.speed;
    this.audio.currentTime = Math.min(this._at, this.duration);
  }

  _ownTime() {
    return this.playing ? this._at + ((performance.now() - this._since) / 1000) * this.speed : this._at;
  }

  _anchor(t) {
    this._at = t;
    this._since = performance.now();
  }

  _audioDrives() {
    const a = this.audio;
    return this.hasAudio && !a.paused && !a.ended && !a.seeking && a.readyState >= 2;
  }

  // The time now (also ends or loops playback at the end of the take).
  now() {
    let t;
    if (!this.playing) return this._at;
    if (this._audioDrives()) {
      t = this.audio.currentTime;
      this._anchor(t);
    } else if (this.hasAudio && !this.audio.paused && (this.audio.seeking || this.audio.readyState < 3)) {
      t = this._at; // the audio is seeking or waiting for data: hold, and go on with it
      this._since = performance.now();
    } else {
      t = this._ownTime();
    }
    if (t >= this.duration) {
      if (this.loop) {
        this.seek(0);
        if (this.hasAudio && this.audio.paused) this.audio.play().catch(() => {}); // it stopped at its end
        return 0;
      }
      this.pause();
      this.seek(this.duration);
      if (this.onend) this.onend();
      return this.duration;
    }
    return t;
  }

  play() {
    if (this.playing) return;
    if (this._at >= this.duration - 1e-3) this._at = 0;
    this.playing = true;
    this._anchor(this._at);
    if (this.hasAudio) {
      this.audio.playbackRate = this.speed;
      if (Math.abs(this.audio.currentTime - this._at) > 0.01) this.audio.currentTime = this._at;
      this.audio.play().catch(() => {}); // a browser that refuses sound: the own clock goes on
    }
  }

  pause() {
    if (!this.playing) return;
    const t = this._audioDrives() ? this.audio.currentTime : this._ownTime();
    this.playing = false;
    this._at = Math.min(t, this.duration);
    if (this.hasAudio) {
      this.audio.pause();
      this.audio.currentTime = this._at;
    }
  }

  seek(t) {
    t = Math.max(0, Math.min(this.duration, t));
    this._anchor(t);
    if (this.hasAudio) this.audio.currentTime = t;
  }

  setSpeed(speed) {
    if (this.playing) this._anchor(this._ownTime());
    this.speed = speed;
    this.audio.playbackRate = speed;
  }
}
