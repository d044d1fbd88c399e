"""Physics tests of the compiled kernel (``monkeystudy.kernel``), mirroring its modules."""
