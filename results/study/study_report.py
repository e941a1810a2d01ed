"""The study report (placeholder until the module is written)."""
