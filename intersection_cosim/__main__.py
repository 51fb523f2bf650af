import sys

from intersection_cosim.cli import main

sys.exit(main())
