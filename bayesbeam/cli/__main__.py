import sys

from bayesbeam.cli import main

sys.exit(main())
