"""``python -m neuronav``: the command line."""

from neuronav.cli import main

raise SystemExit(main())
