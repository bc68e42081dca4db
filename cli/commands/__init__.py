"""One module per subcommand (see cli.main)."""
