import sys

if sys.argv[1:2] == ["signals"]:
    from tests.hostile.trials import main
    sys.exit(main(sys.argv[2:]))
if sys.argv[1:2] == ["readme"]:
    from tests.hostile.report import main
    sys.exit(main(sys.argv[2:]))
from tests.hostile.battery import main

sys.exit(main())
