"""A resident study service: ``monkeystudy serve`` keeps an interpreter with the kernels loaded
and a warm worker pool; ``monkeystudy run STUDY --server [--socket PATH]`` hands it the
study.

A run from the command line pays ~1 s before its first block: the interpreter, numpy, numba
(whose first dispatch imports scipy.linalg), the cached kernels, forking the pool. Against a
100,000-point map (1.5 s of simulation on two idle cores) that is most of the overhead. The service
pays it once; each run then costs its blocks, the consolidation, and ~0.1 s for the thin
client (which imports neither numpy nor numba).

The run itself is the command line's (:func:`monkeystudy.study.command.execute_run`, the same
:func:`~monkeystudy.study.runner.run_study`): same datasets, same resume, same exit codes. A
server runs one study at a time; another client waits for its turn.

Protocol (version :data:`PROTOCOL`): one JSON object per line over a Unix socket (a socket
file, mode 0600: only its owner can connect). The client sends one request::

    {"protocol": 1, "op": "run", "study": ABS, "shown": AS_TYPED, "cwd": CWD, "out": ABS|null,
     "dry_run": false, "command": "monkeystudy run ...", "source_sha256": HEX}
    {"protocol": 1, "op": "ping"} | {"protocol": 1, "op": "stop"}

and reads ``{"out": LINE}`` / ``{"err": LINE}`` until ``{"exit": CODE}`` (or, for ``ping``,
``{"pid": ..., "workers": ..., "source_sha256": ..., "version": ...}``). The client half-closes
its side on Ctrl-C: the server stops the run (finished blocks stay saved) and answers exit 3.

A server refuses a run when its code is not the client's (``source_sha256``, every source file of
the package): an edited package needs a restarted server, never a dataset computed by old code
under the new code's key.

* :mod:`.client` - the thin client (standard library only: it must start fast) and the
  protocol's pieces both sides use;
* :mod:`.server` - the server: kernels loaded, a warm pool, one study at a time.
"""
