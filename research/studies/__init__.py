"""Studies: one module each, a question, its candidates and the rule (``research.rule``).

``collapsed_runs``: the study that chose today's default layout, ``ss12``. The questions
asked before it, and their verdicts, are in CHANGELOG.md (the scripts at their commits).
"""
