"""CLI commands: platform (registered on the shared app)."""
