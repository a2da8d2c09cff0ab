"""The analysis package's tests, run from python/ with
`/usr/bin/python3 -m unittest discover -s tests -t .`."""
