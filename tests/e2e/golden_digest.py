#!/usr/bin/env python3
"""The golden digest of a per-scan CSV (tests/e2e/golden.sh): small enough to keep in the tree,
sharp enough that a change of behaviour shows.

  golden_digest.py IN.csv OUT.csv

OUT holds IN's header, every 50th row (the first included) as it is, and after a line `#all`,
per column: for a column of floats, the sum over every row of its finite numbers and how many were
not (`sum|n_nan`); for a column of integers (utime, seq, quality flags) or of words (the phase), a
hash of the whole column (`h<hex>`, a word), exact. A stateful estimator's change at one scan
carries into the kept rows; a flag or phase that changes on any one scan changes its hash.
numdiff then compares the numbers with a tolerance and the words exactly.
"""
import csv
import hashlib
import math
import sys

KEEP_EVERY = 50


def number(text):
    try:
        return float(text)
    except ValueError:
        return None


def is_integer(text):
    return text.lstrip("-").isdigit()


def main(src, dst):
    with open(src, newline="") as f:
        rows = list(csv.reader(f))
    if len(rows) < 2:
        sys.exit(f"{src}: expected a header and at least one row, got {len(rows)} lines")
    header, body = rows[0], rows[1:]
    summary = []
    for c in range(len(header)):
        column = [r[c] for r in body]
        values = [number(v) for v in column]
        floats = all(v is not None for v in values) and not all(is_integer(v) for v in column)
        if floats:
            finite = [v for v in values if math.isfinite(v)]
            summary.append(f"{math.fsum(finite)!r}|{len(values) - len(finite)}")
        else:
            summary.append("h" + hashlib.sha256("\n".join(column).encode()).hexdigest()[:16])
    with open(dst, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(body[::KEEP_EVERY])
        w.writerow(["#all"])
        w.writerow(summary)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: golden_digest.py IN.csv OUT.csv")
    main(sys.argv[1], sys.argv[2])
