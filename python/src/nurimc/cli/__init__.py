"""The `nurimc` command-line tool."""
