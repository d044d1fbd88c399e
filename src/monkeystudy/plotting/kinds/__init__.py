"""One module per step kind, named as the kind: its ``DRAWINGS`` say how each figure the kind
declares (:attr:`monkeystudy.study.steps.base.StepKind.figures`) is drawn, keyed by ``(kind,
suffix)``. The report loads the module of every kind in the step registry
(:func:`monkeystudy.plotting.report.kind_drawings`), so a new kind's figures are its own module
here, its ``plot_*`` functions exported from :mod:`monkeystudy.plotting` and its figures in the
table of :mod:`monkeystudy.plotting.report`."""
