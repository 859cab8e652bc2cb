"""The HTTP API (v1): ``create_app(settings)`` in ``app.api.main``."""
