"""The study "where coupling pays" (`python3 -m cli study`): which DE zone and bridging band
give the full model's answer, and how much cheaper. plan: which runs; runs: running them;
table: the figures read back from their folders; report: the table, plots and page."""
