"""python -m hex_control.cli: hexctl."""

import sys

from hex_control.cli import main

sys.exit(main())
