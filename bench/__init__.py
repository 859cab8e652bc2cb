"""Benchmarks: speed and cost, each against a baseline measured in the same run.

Run from the repository root as ``.venv/bin/python -m bench.<name> [options]`` (each
module's docstring gives its command); shared helpers are in ``bench._common``. Kept here:
the benchmarks whose figures README.md and docs/ quote. How settings were chosen is
``research/``, not here.
"""
