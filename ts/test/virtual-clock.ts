/** A clock for deterministic timing tests: stub setTimeout/clearTimeout with it (vi.stubGlobal). */

/** setTimeout/clearTimeout on a clock that moves only when told (fractions of a ms kept). */
export class VirtualClock {
  now = 100_000;
  private timers: Array<{ at: number; order: number; run: () => void }> = [];
  private order = 0;

  setTimeout = (run: () => void, ms = 0): number => {
    const order = ++this.order;
    this.timers.push({ at: this.now + Math.max(0, ms), order, run });
    return order;
  };

  clearTimeout = (handle: unknown): void => {
    this.timers = this.timers.filter((t) => t.order !== handle);
  };

  /** Run the next timer (in time order, then in the order set); false if none is left. */
  step(): boolean {
    if (this.timers.length === 0) return false;
    this.timers.sort((a, b) => a.at - b.at || a.order - b.order);
    const next = this.timers.shift() as { at: number; run: () => void };
    this.now = Math.max(this.now, next.at);
    next.run();
    return true;
  }
}

/** Let every promise reaction that is ready run (a real macrotask turn: the microtasks drain first). */
export const settle = (): Promise<void> => new Promise((resolve) => setImmediate(resolve));
