"""Studies: drivers that run the library's models many times and chart what they find — the
model ladder (``ladder``), the stability and well-posedness maps (``stability``,
``wellposed``), regularization against the augmented Lagrangian (``compare``), the benchmark
suites (``bench``, ``bench_krylov``) and the depth-averaged model's validation tables
(``savage_hutter``). They use the library only through its public API (configs, the
simulation, the models' factories) and nothing in the library imports them; the CLI
commands ``ladder``, ``stability``, ``wellposedness``, ``compare``, ``bench`` call them."""
