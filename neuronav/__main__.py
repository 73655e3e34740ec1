"""``python -m neuronav``: the command line, as the ``neuronav`` script runs it (garbage-collector settings too)."""

from neuronav.runs.cli import console_main

raise SystemExit(console_main())
