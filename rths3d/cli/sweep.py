"""CLI commands: sweep (registered on the shared app)."""
