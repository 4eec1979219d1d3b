"""Writes tsA-shift.csv: footA's timestamps.csv with 12.345 s added to every time (a recording
whose clock did not start at zero). Run from the folder that holds footA/."""
import csv

rows = list(csv.reader(open("footA/timestamps.csv")))
with open("tsA-shift.csv", "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(rows[0])
    for r in rows[1:]:
        w.writerow([r[0], repr(float(r[1]) + 12.345)])
