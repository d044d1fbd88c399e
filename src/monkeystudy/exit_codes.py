"""Exit codes of the ``monkeystudy`` commands (README, "Exit codes")."""
#: done
EXIT_OK = 0
#: the run failed (a task raised, a dataset could not be written, no server to run on)
EXIT_FAILED = 1
#: invalid input: a study file, an option, a missing file
EXIT_INVALID = 2
#: interrupted or partial: finished blocks are saved, rerun to resume
EXIT_INTERRUPTED = 3
