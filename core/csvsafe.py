"""CSV exports that a spreadsheet opens as text, never as formulas (OWASP, "CSV Injection").

A cell a user typed (a delivery's contents, a receiver's name) that starts with = + - @, a tab
or a carriage return would run as a formula in Excel or LibreOffice (`=HYPERLINK(...)`
leaks data, `=1+2` computes); such a cell is written with a single quote in front, which the
spreadsheet shows as text. Numbers are written as they are. Every CSV export writes through
`csv_writer`.
"""

import csv

FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def cell_safe(value):
    if isinstance(value, str) and value.startswith(FORMULA_STARTS):
        return "'" + value
    return value


class SafeWriter:
    """csv.writer's writerow/writerows with every text cell made safe."""

    def __init__(self, stream, **options):
        self._writer = csv.writer(stream, **options)

    def writerow(self, row):
        return self._writer.writerow([cell_safe(value) for value in row])

    def writerows(self, rows):
        for row in rows:
            self.writerow(row)


def csv_writer(stream, **options) -> SafeWriter:
    return SafeWriter(stream, **options)
