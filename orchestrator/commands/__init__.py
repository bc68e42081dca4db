"""One module per subcommand (see orchestrator.cli)."""
