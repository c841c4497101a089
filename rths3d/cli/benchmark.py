"""CLI commands: benchmark (registered on the shared app)."""
