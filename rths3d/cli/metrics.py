"""CLI commands: metrics (registered on the shared app)."""
