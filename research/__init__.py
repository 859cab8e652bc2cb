"""Research: how the engine's settings and shipped data are chosen, kept out of the product.

Run from the repository root as ``python -m research.<module>`` (research/README.md):
``research.extract`` (stage 1: what every study needs of every model of the tuning sources),
``research.study`` (the sources as a study reads them, each source's local words fitted on
the others), ``research.rule`` (leave one source out, the paired bootstrap, the tests that
decide), ``research.studies`` (a study: a question, its candidates and the rule) and
``research.artefacts`` (the builders of the data ``core/data`` ships).
"""
