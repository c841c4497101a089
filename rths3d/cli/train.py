"""CLI commands: train (registered on the shared app)."""
