"""Fuzz suite of issue 16: bad inputs in five families, each input classified by its outcome.

=====================  ==========================================================================
module                 family
=====================  ==========================================================================
``test_constructors``  constructor inputs: systems, polytopes, observers and their ``reset``
``test_samples``       observer sample sequences: NaN, inf, huge, wrong-length, time-stamp faults
``test_solver_faults`` solver faults: LP / SDP / MIQP answers corrupted, wrong verdicts, crashes
``test_cli``           ``hybobs`` invocations with a bad value for every option
``test_saved_files``   corrupted regions and gains files
=====================  ==========================================================================

``common`` holds the outcome classes, the classifier helpers and the hypothesis settings
(derandomised, no example database, no deadline, a small ``max_examples``); ``strategies`` the
shared strategies of bad values.  Each family module exposes ``FAMILY``: its targets (one
hypothesis strategy and one ``try_one(value) -> outcome`` each), which the tests run under pytest
and ``python -m tests.fuzz_summary`` runs outside it with a fixed seed to print the table of
inputs tried and outcomes per class.
"""
