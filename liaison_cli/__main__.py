from liaison_cli.cli import main

main()
