import sys

from tests.hostile.battery import main

sys.exit(main())
