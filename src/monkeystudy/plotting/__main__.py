"""``python -m monkeystudy.plotting DIR [DIR ...] [--force] [--no-animation]``: draw a study's
figures (the same as ``monkeystudy report DIR``)."""
from .report import main

raise SystemExit(main())
