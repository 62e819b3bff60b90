from sb3_reinforce.lab.compare.cli import main

main()
