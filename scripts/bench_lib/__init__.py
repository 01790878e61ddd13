"""Helpers and subcommands for scripts/bench."""
