from clothtool.cli import main

main()
