"""Executes a notebook's code cells in order, headless (matplotlib's Agg backend), in one
namespace, as Jupyter would; exits non-zero on the first cell that raises. The test suite runs
examples/analysis.ipynb with it on synthetic runs, so that the example cannot rot.
Usage: /usr/bin/python3 tests/run_notebook.py NOTEBOOK.ipynb"""
import json
import os
import sys
import traceback

os.environ.setdefault("MPLBACKEND", "Agg")


def main(path):
    with open(path, encoding="utf-8") as f:
        notebook = json.load(f)
    namespace = {"__name__": "__main__"}
    for k, cell in enumerate(notebook["cells"]):
        if cell["cell_type"] != "code":
            continue
        source = "".join(cell["source"])
        try:
            exec(compile(source, f"{path} cell {k}", "exec"), namespace)
        except Exception:
            traceback.print_exc()
            print(f"error: {path}: code cell {k} raised", file=sys.stderr)
            return 1
    print(f"{path}: every code cell ran")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
