//! Benchmarks: see `benches/` and `benches/RESULTS.md`.
