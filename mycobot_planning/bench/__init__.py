"""Benchmarks: ``python -m mycobot_planning.bench SCENARIO [--repeat N] [--seed S]``.

Each scenario prints one JSON object per repeat and a final summary line (``"summary": true``)
whose keys are a stable contract for tools that read them. Timing lives here, never in tests.
"""
