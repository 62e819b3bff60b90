import sys

from sb3_reinforce.lab.zoo.cli import main

if __name__ == "__main__":
    sys.exit(main())
