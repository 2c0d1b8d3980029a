"""Progress lines on stderr: `  [#####...............] label 12 / 40 ( 30.0%)    6.2 s  note`."""
import sys
import time


class Progress:
    """Progress of `label` towards `total` (a simulated time, or a number of items).

    update(done): a line at most every `every` seconds (always with force=True); fmt: the format of `done`.
    step(note): one more item done, always reported, with its note."""

    def __init__(self, label, total=None, every=2.0, fmt="9.4g", stream=None):
        self.label, self.total, self.every, self.fmt = label, total, every, fmt
        self.stream = stream or sys.stderr
        self.done = 0
        self.start = self.last = time.perf_counter()

    def update(self, done, total=None, force=False, note=""):
        total = self.total if total is None else total
        self.done = done
        now = time.perf_counter()
        if force or now - self.last >= self.every:
            self.last = now
            fraction = done / total if total else 1.0
            bar = "#" * int(round(20 * fraction))
            print(f"  [{bar:.<20s}] {self.label} {done:{self.fmt}} / {total:g} ({100 * fraction:5.1f}%) "
                  f"{now - self.start:6.1f} s{note}", file=self.stream, flush=True)

    def step(self, note):
        self.update(self.done + 1, force=True, note=f"  {note}")
