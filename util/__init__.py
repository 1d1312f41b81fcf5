"""Plumbing every package shares, below them all (it imports none of them): the error types
(`errors`), atomic files, strict JSON and checksums (`files`), declared settings (`fields`),
the progress callback commands draw (`progress`) and the one command-line error path of
`benchmarks.run`, `calibrate` and `sim.render` (`cli`)."""
