from sb3_reinforce.lab.compare.command import main

main()
