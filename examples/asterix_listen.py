"""Listen to shipradar's ASTERIX stream and print the plots of each scan.

    shipradar run --example single_missile --realtime 10 --asterix udp://127.0.0.1:8600 &
    python examples/asterix_listen.py [--port 8600] [--scans N]

Decodes each UDP datagram with the ``asterix-decoder`` package (PyPI; C++ decoder with its
own CAT048/CAT034 definitions, nothing from shipradar): CAT048 records are plots, a CAT034
north marker (I034/000 = 1) closes a radar's scan and carries the radar's position
(I034/120), which a tracker needs because the radar is on a moving ship.
"""

from __future__ import annotations

import argparse
import socket
from collections import defaultdict

import asterix  # pip install asterix-decoder


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, default=8600)
    ap.add_argument("--scans", type=int, default=None, help="stop after N north markers")
    args = ap.parse_args()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
    sock.bind((args.host, args.port))
    plots = defaultdict(list)  # (SAC, SIC) -> plots since the last north marker
    markers = 0
    try:
        while args.scans is None or markers < args.scans:
            for rec in asterix.parse(sock.recv(65536)):
                src = (rec["I010"]["SAC"]["val"], rec["I010"]["SIC"]["val"])
                if rec["category"] == 48:
                    plots[src].append((rec["I140"]["ToD"]["val"], rec["I040"]["RHO"]["val"],
                                       rec["I040"]["THETA"]["val"]))
                elif rec["category"] == 34 and rec["I000"]["MsgTyp"]["val"] == 1:
                    pos = rec["I120"]
                    print(f"radar {src[0]}/{src[1]} north at ToD {rec['I030']['ToD']['val']:.3f} s"
                          f", antenna {pos['LAT']['val']:.5f}° {pos['Lon']['val']:.5f}° "
                          f"{pos['Height']['val']} m: {len(plots[src])} plot(s)")
                    for tod, rho, theta in plots.pop(src, []):
                        print(f"    ToD {tod:10.3f} s  range {rho:8.3f} NM  azimuth "
                              f"{theta:7.3f}°")
                    markers += 1
    except KeyboardInterrupt:
        pass
    finally:
        sock.close()


if __name__ == "__main__":
    main()
