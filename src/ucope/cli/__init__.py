"""Command line interface: ``ucope <command>``."""
