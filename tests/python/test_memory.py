# SPDX-License-Identifier: BSD-2-Clause
"""Memory over many output steps (issue 37 item 12): a run's resident set
must not grow with the number of output steps written. Parallel HDF5 1.10.8
kept about 10-20 kB a rank for every object created in the output file
(the /xdmf views of each step) until the library closed; module output now
closes and reopens the library every 64 output steps. 600 output steps (two
views each) of hang 9 x 7 on 2 ranks: on a0abf83 rank 0 grew by 25 MB
between output steps 100 and 590 (53 -> 78 MB), now by 0.3 MB; what is
kept is bounded by 64 steps' worth (about 2 MB), so 4 MB is the line."""
import subprocess
import time

from nunorun import exe, mpiexec, namelist


def vm_rss_mib(pid):
    for line in open(f"/proc/{pid}/status"):
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return None


def test_resident_memory_does_not_grow_with_output_steps(tmp_path):
    nml = tmp_path / "m.nml"
    nml.write_text(namelist("m.h5", scene="scene='hang'", lattice="nx=9 ny=7", time="t_end=0.6 dt=0.001",
                            output="output_interval=0.001 write_velocity=.true."))
    proc = subprocess.Popen([mpiexec(), "-n", "2", "--oversubscribe", exe(), str(nml)], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    rank, seen, rss = None, 0, {}
    deadline = time.time() + 300
    for line in proc.stdout:
        if not line.startswith("t ="):
            continue
        seen += 1
        if rank is None:
            kids = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
            ranks = [int(k) for k in kids if b"nuno" in open(f"/proc/{k}/cmdline", "rb").read()]
            rank = min(ranks) if ranks else None
        if rank is not None and seen in (100, 590):
            rss[seen] = vm_rss_mib(rank)
        if time.time() > deadline:
            proc.kill()
            break
    proc.communicate(timeout=60)
    assert proc.returncode == 0
    assert set(rss) == {100, 590} and None not in rss.values(), rss
    assert rss[590] - rss[100] < 4.0, rss
