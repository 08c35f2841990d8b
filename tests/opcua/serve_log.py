"""Serve a logger's CSV over OPC UA, row by row at a chosen pace, as a welding cell would.

The e2e tests of `waamtwin follow` with `[live.opcua]` run this with Python's asyncua (a
server we did not write) on 127.0.0.1. Each named column is a Double variable `ns=2;s=NAME`
under the object `Cell`; row t is written to all of them with the source timestamp
origin + t, so the client can tell rows apart and put them back on the build's clock.

    python serve_log.py --log LOG.csv --port P --origin-unix-s T0 --speed 20 \
        --column tc1=2 --column tc2=3 [--from-row A] [--to-row B] [--exit-after-row K]

The server waits (at most --wait-s) for a client to monitor every variable before it writes
the first row, and once more after a restart, so that a test loses nothing to the start-up.
--exit-after-row K ends the process at once after row K, with no goodbye: a server that dies.
"""

import argparse
import asyncio
import csv
import datetime
import math
import os
import sys
import time

from asyncua import Server, ua

EPOCH = datetime.datetime(1970, 1, 1, tzinfo=datetime.timezone.utc)


def arguments():
    a = argparse.ArgumentParser()
    a.add_argument("--log", required=True)
    a.add_argument("--port", type=int, required=True)
    a.add_argument("--origin-unix-s", type=float, required=True)
    a.add_argument("--speed", type=float, default=1.0)
    a.add_argument("--column", action="append", required=True, help="NAME=INDEX")
    a.add_argument("--time-column", type=int, default=0)
    a.add_argument("--from-row", type=int, default=0)
    a.add_argument("--to-row", type=int, default=None)
    a.add_argument("--exit-after-row", type=int, default=None)
    a.add_argument("--wait-s", type=float, default=60.0)
    return a.parse_args()


def monitored(server):
    """How many monitored items the server's subscriptions hold."""
    subs = server.iserver.subscription_service.subscriptions.values()
    return sum(len(s.monitored_item_srv._monitored_items) for s in subs)


async def main():
    args = arguments()
    columns = [(c.split("=")[0], int(c.split("=")[1])) for c in args.column]
    with open(args.log, newline="") as f:
        rows = list(csv.reader(f))[1:]
    rows = rows[args.from_row : args.to_row]

    server = Server()
    await server.init()
    server.set_endpoint(f"opc.tcp://127.0.0.1:{args.port}/waamtwin/")
    server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
    ns = await server.register_namespace("urn:waamtwin:test-cell")
    cell = await server.nodes.objects.add_object(ns, "Cell")
    nodes = [
        await cell.add_variable(ua.NodeId(name, ns), name, ua.Variant(math.nan, ua.VariantType.Double))
        for name, _ in columns
    ]
    async with server:
        print(f"serving on port {args.port}, namespace {ns}", flush=True)
        deadline = time.monotonic() + args.wait_s
        while monitored(server) < len(nodes):
            if time.monotonic() > deadline:
                print("no client monitored every variable in time", file=sys.stderr)
                return 1
            await asyncio.sleep(0.05)
        start, t_first = time.monotonic(), None
        for k, row in enumerate(rows, start=args.from_row):
            t = float(row[args.time_column])
            t_first = t if t_first is None else t_first
            wait = start + (t - t_first) / args.speed - time.monotonic()
            if wait > 0:
                await asyncio.sleep(wait)
            stamp = EPOCH + datetime.timedelta(seconds=args.origin_unix_s + t)
            for node, (_, col) in zip(nodes, columns):
                cell_text = row[col].strip() if col < len(row) else ""
                if not cell_text:
                    continue
                value = ua.DataValue(
                    ua.Variant(float(cell_text), ua.VariantType.Double),
                    SourceTimestamp=stamp,
                    ServerTimestamp=stamp,
                )
                await server.write_attribute_value(node.nodeid, value)
            if args.exit_after_row is not None and k >= args.exit_after_row:
                print(f"exiting after row {k} (t = {t} s)", flush=True)
                os._exit(3)
        # Let the last publish go out before the server closes.
        await asyncio.sleep(1.0)
        print(f"served rows {args.from_row}..{args.from_row + len(rows)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(asyncio.run(main()))
