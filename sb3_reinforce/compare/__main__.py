from sb3_reinforce.compare.cli import main

main()
