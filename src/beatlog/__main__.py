"""``python -m beatlog``: the ``beatlog`` command, where its script is not on ``PATH``."""

from beatlog.cli.main import main

raise SystemExit(main())
