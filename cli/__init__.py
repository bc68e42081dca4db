"""The command line, the top layer: `python3 -m cli SUBCOMMAND ...`.

Commands (`cli.commands`), batches and Slurm arrays, ParaView renders and `attach` for scripts
run under YADE's own launcher. Everything below it (cases, the orchestrator, the partners)
knows nothing of it."""
