// Counts an encoder report stream (messages of WebSocket topic controllers/<id>/reports): every frame,
// the rate in frames/s, and the gaps: `gap` messages of the gateway (frames it could not send this
// page), jumps of the frame counter, and the stream's `controller_overruns` notices (frames the
// controller itself could not send: its error 87). Counting is O(1) per frame so that 500 frames/s
// cost nothing; drawing is someone else's business.

const RATE_WINDOW_MS = 1000;

export class ReportStats {
  constructor() {
    this.frames = 0;
    this.gaps = 0;
    this.missed = 0;  // frames known to be lost (every kind of gap)
    this.lostInController = 0;  // of those, the ones the controller could not send
    this.lastControllerSeq = null;
    this.rate = 0;
    this.rateMark = { at: performance.now(), frames: 0 };
  }

  // One WebSocket message of the reports topic; returns the frame's data for an event, else null.
  count(msg) {
    if (msg.type === "gap") {
      this.gaps += 1;
      this.missed += msg.missed ?? Math.max(0, (msg.to ?? 0) - (msg.from ?? 0) + 1);
      this.lastControllerSeq = null;  // the jump after a gateway gap is that same gap
      return null;
    }
    if (msg.type !== "event") return null;
    const overruns = msg.data?.controller_overruns;
    if (typeof overruns === "number") {
      this.gaps += 1;
      this.missed += overruns;
      this.lostInController += overruns;
      return null;
    }
    this.frames += 1;
    const seq = msg.data?.controller_seq;
    if (typeof seq === "number") {
      const last = this.lastControllerSeq;
      if (last !== null && seq > last + 1) {
        this.gaps += 1;
        this.missed += seq - last - 1;
      }
      this.lastControllerSeq = seq;  // a smaller one: the controller reconnected and counts afresh
    }
    return msg.data;
  }

  // frames/s over the last second or so; call it about once a second.
  updateRate(now = performance.now()) {
    const elapsed = now - this.rateMark.at;
    if (elapsed >= RATE_WINDOW_MS) {
      this.rate = ((this.frames - this.rateMark.frames) * 1000) / elapsed;
      this.rateMark = { at: now, frames: this.frames };
    }
    return this.rate;
  }

  summary() {
    const rate = this.rate >= 10 ? this.rate.toFixed(0) : this.rate.toFixed(1);
    const inController = this.lostInController ? `, ${this.lostInController} in the controller` : "";
    const gaps = this.gaps
      ? `${this.gaps} gap${this.gaps > 1 ? "s" : ""} (${this.missed} frames lost${inController})`
      : "no gaps";
    return `${rate} frames/s · ${this.frames} frames · ${gaps}`;
  }
}
