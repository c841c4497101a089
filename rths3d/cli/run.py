"""CLI commands: run (registered on the shared app)."""
