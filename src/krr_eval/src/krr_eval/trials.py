"""Per-trial tables as written by the core CLIs: a CSV header and one row (or several) per
trial, trial index in the first column. Columns are looked up by name from the header, never
by position, and every conversion error names the file, line and column."""
import csv
import io

TRUE = {"1", "true", "yes", "y", "t"}
FALSE = {"0", "false", "no", "n", "f"}


class TrialTable(object):
    """Rows of strings under a header; `source` names where they came from (for errors)."""

    def __init__(self, header, rows, source="<trials>"):
        self.header = list(header)
        self.rows = [list(r) for r in rows]
        self.source = source
        self._index = {h: i for i, h in enumerate(self.header)}
        if len(self._index) != len(self.header):
            raise ValueError("%s: duplicate column names in header %s" % (source, self.header))

    # ---- reading and writing
    @classmethod
    def from_text(cls, text, source="<trials>"):
        """Parse CSV text (header line first). Blank lines are skipped; a row with a different
        number of fields than the header is an error naming its line."""
        reader = csv.reader(io.StringIO(text))
        header, rows = None, []
        for row in reader:
            if not row or all(not c.strip() for c in row):
                continue
            if header is None:
                header = [c.strip() for c in row]
                continue
            if len(row) != len(header):
                raise ValueError("%s line %d: %d fields, header has %d (%s)"
                                 % (source, reader.line_num, len(row), len(header),
                                    ",".join(header)))
            rows.append(row)
        if header is None:
            raise ValueError("%s: empty (no CSV header)" % source)
        return cls(header, rows, source)

    @classmethod
    def read(cls, path):
        """Read a trial CSV file."""
        with open(path, newline="") as f:
            return cls.from_text(f.read(), path)

    def to_text(self):
        """CSV text, header first ("\\n" line ends)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.header)
        w.writerows(self.rows)
        return buf.getvalue()

    def __len__(self):
        return len(self.rows)

    # ---- columns
    def has(self, name):
        return name in self._index

    def find(self, *names):
        """The first of `names` present in the header, or None."""
        for n in names:
            if n in self._index:
                return n
        return None

    def _col(self, name):
        if name not in self._index:
            raise ValueError("%s: no column '%s' (columns: %s)"
                             % (self.source, name, ", ".join(self.header)))
        return self._index[name]

    def strings(self, name):
        """The column as stripped strings."""
        i = self._col(name)
        return [r[i].strip() for r in self.rows]

    def floats(self, name):
        """The column as floats; an unparsable cell is an error naming line and column."""
        i = self._col(name)
        out = []
        for k, r in enumerate(self.rows):
            try:
                out.append(float(r[i]))
            except ValueError:
                raise ValueError("%s data row %d column '%s': '%s' is not a number"
                                 % (self.source, k + 1, name, r[i]))
        return out

    def ints(self, name):
        """The column as integers."""
        out = []
        for k, v in enumerate(self.floats(name)):
            if v != int(v):
                raise ValueError("%s data row %d column '%s': %r is not an integer"
                                 % (self.source, k + 1, name, v))
            out.append(int(v))
        return out

    def bools(self, name):
        """The column as booleans (1/0, true/false, yes/no)."""
        i = self._col(name)
        out = []
        for k, r in enumerate(self.rows):
            v = r[i].strip().lower()
            if v in TRUE:
                out.append(True)
            elif v in FALSE:
                out.append(False)
            else:
                try:
                    out.append(float(v) != 0.0)
                except ValueError:
                    raise ValueError("%s data row %d column '%s': '%s' is not a boolean"
                                     % (self.source, k + 1, name, r[i]))
        return out

    # ---- selections
    def where(self, name, value):
        """Rows whose column `name` equals `value` (compared as stripped strings)."""
        i = self._col(name)
        v = str(value)
        return TrialTable(self.header, [r for r in self.rows if r[i].strip() == v], self.source)

    def where_true(self, name):
        """Rows whose boolean column `name` is true."""
        flags = self.bools(name)
        return TrialTable(self.header, [r for r, f in zip(self.rows, flags) if f], self.source)

    def select(self, predicate):
        """Rows for which predicate(dict of column -> string) is true."""
        return TrialTable(self.header,
                          [r for r in self.rows if predicate(dict(zip(self.header, r)))],
                          self.source)

    def head(self, n):
        """The first n rows."""
        return TrialTable(self.header, self.rows[:n], self.source)

    def trial_column(self):
        """Name of the trial index column (the first)."""
        if not self.header:
            raise ValueError("%s: no columns" % self.source)
        return self.header[0]

    def trial_indices(self):
        """The first column as integers."""
        return self.ints(self.trial_column())
