"""The repository's Python is kept within 100 columns, the width .clang-format gives the C++
(ARCHITECTURE.md, "Conventions"): every .py file under the source tree, build folders left out."""
import os
import tempfile
import unittest

REPOSITORY = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
WIDTH = 100
SKIPPED_FOLDERS = {".git", "__pycache__", "campaigns"}  # and every build* folder


def python_files(root):
    for folder, subfolders, files in os.walk(root):
        subfolders[:] = sorted(d for d in subfolders
                               if d not in SKIPPED_FOLDERS and not d.startswith("build"))
        for name in sorted(files):
            if name.endswith(".py"):
                yield os.path.join(folder, name)


def long_lines(path, width=WIDTH):
    """(line number, length) of each line of path longer than width characters."""
    with open(path, encoding="utf-8") as f:
        lengths = (len(line.rstrip("\n")) for line in f)
        return [(number, length) for number, length in enumerate(lengths, start=1)
                if length > width]


class LineWidth(unittest.TestCase):
    def test_the_check_finds_a_long_line(self):
        with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
            f.write("x = 1\n" + "y = '" + "a" * WIDTH + "'\n")
        try:
            self.assertEqual(long_lines(f.name), [(2, WIDTH + 6)])
        finally:
            os.unlink(f.name)

    def test_every_python_file_within_the_width(self):
        files = list(python_files(REPOSITORY))
        self.assertGreater(len(files), 20)  # the tree was found
        found = [f"{os.path.relpath(path, REPOSITORY)}:{number}: {length} columns"
                 for path in files for number, length in long_lines(path)]
        self.assertEqual(found, [], "lines over %d columns:\n%s" % (WIDTH, "\n".join(found)))


if __name__ == "__main__":
    unittest.main()
