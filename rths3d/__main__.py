from rths3d.cli import main

main()
