"""Studies: drivers that run the solver's models many times and chart what they find — the
model ladder (``ladder``), the stability and well-posedness maps (``stability``,
``wellposed``), regularization against the augmented Lagrangian (``compare``), the benchmark
suites (``bench``, ``bench_krylov``) and the depth-averaged model's validation tables
(``savage_hutter``); ``benchmarks/`` holds the measurement scripts of the dated reports.

Not installed with ``dpcollapse``: run from the checkout's root, ``python -m studies COMMAND``
(``cli.py``). They use the solver through its public API (docs/architecture.md, "Studies";
``tests/studies/test_clients.py`` checks it) and nothing in the solver imports them."""
