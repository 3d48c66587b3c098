"""`python -m asi_gateway ...`: the same as `asi-gateway-client ...`."""

import sys

from .cli import main

sys.exit(main())
