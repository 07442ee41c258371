"""`python -m resus`: the `resus` command line."""

from resus.cli.app import main

if __name__ == "__main__":
    main()
