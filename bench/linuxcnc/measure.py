#!/usr/bin/env python3
"""The motion time LinuxCNC 2.9 takes on a part program with the thermal gantry's limits: the
reference machplan's planned motion is compared with (bench/results/cut_order.txt).

    bench/linuxcnc/measure.py PROGRAM.ngc [--path-mode 'G64 P0.01'] ...

For each path mode given (default: the program as written, then G64 with no tolerance, the
fastest blending LinuxCNC has), the program is run on LinuxCNC's simulated controller
(Debian's linuxcnc-uspace, gantry.ini and gantry.hal beside this file, headless through
linuxcncrsh on port 5007) and the time the machine spent out of position (moving) is read from
the HAL integrator the configuration adds. Torch words (M3, M5) and dwells (G4) stop the motion
in LinuxCNC as in machplan, so this is the same motion time machplan reports as planned
motion. The runs take real time (the simulator paces the servo thread at 1 ms).

Needs root (rtapi_app then runs as the user RTAPI_UID names: nobody). Prints one line per path
mode and the best; exit 1 when LinuxCNC does not come up or the program does not run.
"""
import argparse
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def wait_for_port(port, seconds):
    """A connection to linuxcncrsh that has answered its handshake."""
    t0 = time.time()
    while time.time() - t0 < seconds:
        try:
            sock = socket.create_connection(('localhost', port), timeout=5)
            f = sock.makefile('rw')
            f.write('hello EMC machplan 1.0\n')
            f.flush()
            if f.readline().startswith('HELLO ACK'):
                return sock
            sock.close()
        except OSError:
            pass
        time.sleep(0.5)
    return None


def children(pid):
    """The processes whose parent is `pid`."""
    out = []
    for entry in os.listdir('/proc'):
        if not entry.isdigit():
            continue
        try:
            with open('/proc/%s/stat' % entry) as f:
                fields = f.read().rsplit(')', 1)[1].split()
            if int(fields[1]) == pid:
                out.append(int(entry))
        except (OSError, IndexError, ValueError):
            pass
    return out


class Rsh:
    def __init__(self, sock):
        self.f = sock.makefile('rw')

    def cmd(self, text):
        self.f.write(text + '\n')
        self.f.flush()
        return self.f.readline().strip()


def run_once(program, path_mode, env, work):
    text = open(program).read()
    if path_mode:
        text = re.sub(r'(?im)^\s*G64[^\n(;]*', path_mode, text) if re.search(r'(?im)^\s*G64', text) \
            else path_mode + '\n' + text
    prog = os.path.join(work, 'program.ngc')
    with open(prog, 'w') as f:
        f.write(text)
    log = open(os.path.join(work, 'linuxcnc.log'), 'w')
    lcnc = subprocess.Popen(['linuxcnc', 'gantry.ini'], cwd=work, env=env, stdout=log, stderr=subprocess.STDOUT)
    try:
        sock = wait_for_port(5007, 60)
        if sock is None:
            raise RuntimeError('linuxcncrsh did not come up (see %s)' % log.name)
        rsh = Rsh(sock)
        for c in ['set enable EMCTOO', 'set echo off', 'set verbose on', 'set estop off',
                  'set machine on', 'set mode manual', 'set home -1']:
            rsh.cmd(c)
        time.sleep(1.0)
        if 'NO' in rsh.cmd('get joint_homed').split()[1:4]:
            raise RuntimeError('the joints did not home')
        rsh.cmd('set mode auto')
        rsh.cmd('set open ' + prog)
        subprocess.run(['halcmd', 'setp', 'motion_time.reset', '1'], env=env, check=True)
        subprocess.run(['halcmd', 'setp', 'motion_time.reset', '0'], env=env, check=True)
        t0 = time.time()
        rsh.cmd('set run')
        started = False
        while time.time() - t0 < 3600:
            status = rsh.cmd('get program_status')
            if 'RUNNING' in status or 'PAUSED' in status:
                started = True
            elif started or time.time() - t0 > 10:
                break
            time.sleep(0.05)
        wall = time.time() - t0
        error = rsh.cmd('get error')
        out = subprocess.run(['halcmd', 'getp', 'motion_time.out'], env=env, check=True, capture_output=True, text=True)
        rsh.cmd('set machine off')
        return float(out.stdout.strip()), wall, error
    finally:
        # The linuxcnc script tears everything down (HAL, rtapi_app, the task) once its display,
        # linuxcncrsh, exits: end that child of it.
        for pid in children(lcnc.pid):
            try:
                os.kill(pid, 15)
            except ProcessLookupError:
                pass
        try:
            lcnc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            lcnc.kill()
            lcnc.wait()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('program')
    ap.add_argument('--path-mode', action='append', help="a path mode line to run with, e.g. 'G64 P0.01'")
    a = ap.parse_args()
    modes = a.path_mode or [None, 'G64']
    best = None
    for mode in modes:
        work = tempfile.mkdtemp(prefix='machplan_lcnc_')
        os.chmod(work, 0o777)
        for name in ('gantry.ini', 'gantry.hal', 'gantry.tbl', 'gantry.var'):
            shutil.copy(os.path.join(HERE, name), work)
            os.chmod(os.path.join(work, name), 0o666)
        env = dict(os.environ, RTAPI_UID='65534', RTAPI_FIFO_PATH=os.path.join(work, 'fifo'))
        try:
            motion, wall, error = run_once(os.path.abspath(a.program), mode, env, work)
        finally:
            shutil.rmtree(work, ignore_errors=True)
        label = mode or 'as written'
        print('%-14s motion %.3f s (program ran %.1f s of wall time)%s' % (label, motion, wall,
              '' if error in ('', 'ERROR OK', 'ERROR') else '; ' + error))
        best = motion if best is None else min(best, motion)
    print('best           motion %.3f s' % best)


if __name__ == '__main__':
    sys.exit(main())
