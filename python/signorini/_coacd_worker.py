"""CoACD in a process of its own, for ``signorini.decomposition`` (run as a script, never imported).

    python _coacd_worker.py IN.npz OUT.npz SETTINGS_JSON

IN holds ``vertices`` (n, 3) float64 and ``faces`` (k, 3) int64; SETTINGS_JSON is
``{"coacd": {run_coacd keywords}, "path": [the parent's sys.path]}``. CoACD's log lines (its
rounds and pieces) go to stdout, where the parent reads them for its progress bar; the pieces go to
OUT (``count``, ``piece_<k>`` (n_i, 3) float64), written whole or not at all.

The parent stops this process by terminating it (Ctrl-C in the parent); should the parent die
without doing so, its end of our stdin closes and this process exits at once, so no orphan goes
on computing. Nothing here imports signorini (the process starts in a few tenths of a second).
"""
import json
import os
import sys
import threading


def _exit_with_parent() -> None:
    # the parent holds our stdin open and never writes to it: end of file means it has gone
    sys.stdin.buffer.read()
    os._exit(3)


def main(argv: list) -> None:
    source, target, options = argv[1], argv[2], json.loads(argv[3])
    sys.path[:] = options["path"]
    threading.Thread(target=_exit_with_parent, daemon=True).start()
    import numpy as np
    import coacd

    with np.load(source) as data:
        vertices, faces = data["vertices"], data["faces"]
    coacd.set_log_level("info")
    parts = coacd.run_coacd(coacd.Mesh(vertices, faces), **options["coacd"])
    partial = target + ".partial"
    with open(partial, "wb") as f:
        np.savez(f, count=len(parts), **{f"piece_{k}": np.asarray(v, dtype=np.float64) for k, (v, _) in enumerate(parts)})
    os.replace(partial, target)
    sys.stdout.flush()
    # at once: a normal exit would wait on the thread reading stdin
    os._exit(0)


if __name__ == "__main__":
    main(sys.argv)
