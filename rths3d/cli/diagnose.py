"""CLI commands: diagnose (registered on the shared app)."""
