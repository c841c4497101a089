"""CLI commands: view (registered on the shared app)."""
