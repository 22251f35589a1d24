#!/usr/bin/env python3
"""delta_boot as a process (docs/flashing.md), with shell-script programs
in real images (host_id image make), so that each of its paths can be
driven: a staged program confirmed, one that crashes on trial, a power loss
during a trial (delta_boot and its program SIGKILLed, then delta_boot
started again), a corrupt boot record, an empty state folder. The programs
wait on a FIFO for the test's commands; the test waits on delta_boot's
output lines, never on sleeps.

Usage: delta_boot_test.py HOST_ID DELTA_BOOT
"""
import errno
import os
import select
import signal
import subprocess
import sys
import tempfile
import time

HOST_ID, DELTA_BOOT = sys.argv[1], sys.argv[2]
failures = []

# The installed program: says how it was started, then obeys the FIFO:
# "stage IMAGE" copies IMAGE to the staging path and reports it, "start"
# asks for the trial.
# Each read opens the FIFO again; one that opens it while the test still
# holds its last command's write end open reads nothing once that closes,
# and opens it again.
V1 = r'''#!/bin/sh
echo "v1 trial=$DELTA_BOOT_TRIAL reverted=$DELTA_BOOT_REVERTED" >> "$STATE_LOG"
while true; do
  read cmd arg < "$FIFO" || continue
  case "$cmd" in
    stage) cp "$arg" "$DELTA_BOOT_STAGING"; echo staged > /proc/self/fd/$DELTA_BOOT_FD ;;
    start) echo start > /proc/self/fd/$DELTA_BOOT_FD ;;
  esac
done
'''
CONFIRMS = '#!/bin/sh\necho "v2 trial=$DELTA_BOOT_TRIAL" >> "$STATE_LOG"\n' \
           'echo confirm > /proc/self/fd/$DELTA_BOOT_FD\nexec sleep 600\n'
CRASHES = '#!/bin/sh\nkill -SEGV $$\n'
HANGS = '#!/bin/sh\nexec sleep 600\n'


def check(ok, what):
    if not ok:
        failures.append(what)
        print("FAIL:", what)


def make_image(work, name, script, version):
    path = os.path.join(work, name + ".sh")
    with open(path, "w") as f:
        f.write(script)
    os.chmod(path, 0o755)
    image = os.path.join(work, name + ".img")
    subprocess.run([HOST_ID, "image", "make", path, "-o", image, "--version", version],
                   check=True, capture_output=True)
    return image


class Boot:
    """delta_boot with its stderr read line by line."""

    def __init__(self, work, extra):
        env = dict(os.environ, FIFO=os.path.join(work, "fifo"),
                   STATE_LOG=os.path.join(work, "started.log"))
        self.p = subprocess.Popen([DELTA_BOOT, "--state-dir", os.path.join(work, "state")] + extra,
                                  stderr=subprocess.PIPE, env=env, start_new_session=True)
        self.log = ""

    def wait_for(self, needle, timeout=30.0):
        end = time.monotonic() + timeout
        while needle not in self.log:
            left = end - time.monotonic()
            if left <= 0:
                return False
            ready, _, _ = select.select([self.p.stderr], [], [], left)
            if ready:
                chunk = os.read(self.p.stderr.fileno(), 65536).decode()
                if not chunk:
                    return needle in self.log
                self.log += chunk
        return True

    def stop(self):
        if self.p.poll() is None:
            self.p.terminate()
        self.p.wait(30)
        self.wait_for("\x00", 0.1)


def command(work, text, timeout=30.0):
    """Writes one command line to the program's FIFO once the program has it
    open for reading; a program that never opens it (it died) fails the
    check instead of blocking the test."""
    end = time.monotonic() + timeout
    while True:
        try:
            fd = os.open(os.path.join(work, "fifo"), os.O_WRONLY | os.O_NONBLOCK)
            break
        except OSError as e:
            if e.errno != errno.ENXIO or time.monotonic() > end:
                check(False, "no program reads the FIFO for %r: %s" % (text, e))
                return
            select.select([], [], [], 0.02)  # polls for a reader another process opens
    try:
        os.set_blocking(fd, True)
        os.write(fd, (text + "\n").encode())
    finally:
        os.close(fd)


def started(work):
    with open(os.path.join(work, "started.log")) as f:
        return f.read().splitlines()


def scenario(name, second, second_version, expect):
    with tempfile.TemporaryDirectory() as work:
        os.mkdir(os.path.join(work, "state"))
        os.mkfifo(os.path.join(work, "fifo"))
        v1 = make_image(work, "v1", V1, "1.0.0")
        v2 = make_image(work, "v2", second, second_version)
        boot = Boot(work, ["--install", v1, "--trial-timeout", "2"])
        check(boot.wait_for("started slot 0 (version 1.0.0"), name + ": v1 starts\n" + boot.log)
        command(work, "stage " + v2)
        check(boot.wait_for("staged slot 1 (version " + second_version), name + ": staged\n" + boot.log)
        command(work, "start")
        expect(work, boot)
        boot.stop()


def confirmed(work, boot):
    check(boot.wait_for("confirmed slot 1 (version 1.1.0"), "confirm\n" + boot.log)
    with open(os.path.join(work, "state", "boot.record"), "rb") as f:
        record = f.read()
    check(record[:4] == b"DBR1" and record[4] == 1, "the record names slot 1 active: %r" % record[:8])
    check(started(work) == ["v1 trial=0 reverted=0", "v2 trial=1"], "started: %s" % started(work))


def crashed(work, boot):
    # The whole line: a read may end in its middle.
    check(boot.wait_for("the new program crashed before it confirmed\n"), "crash rolls back\n" + boot.log)
    check("was killed by signal 11" in boot.log, "the signal is named\n" + boot.log)
    check("rolled back from slot 1 (version 1.1.0" in boot.log, "from slot 1\n" + boot.log)
    check(wait_for_line(work, "v1 trial=0 reverted=3"), "v1 again, told reason 3: %s" % started(work))


def wait_for_line(work, line, timeout=10.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if line in started(work):
            return True
        select.select([], [], [], 0.05)  # polls a file another process writes
    return False


def power_loss(work, boot):
    check(boot.wait_for("on trial, pid"), "trial starts\n" + boot.log)
    os.killpg(boot.p.pid, signal.SIGKILL)  # delta_boot and its program, as a power loss
    boot.p.wait(30)
    again = Boot(work, ["--trial-timeout", "2"])
    check(again.wait_for("the controller restarted during the trial\n"), "power loss\n" + again.log)
    check("rolled back to slot 0 (version 1.0.0" in again.log, "to slot 0\n" + again.log)
    check(wait_for_line(work, "v1 trial=0 reverted=4"), "v1 told reason 4: %s" % started(work))
    again.stop()


scenario("confirm", CONFIRMS, "1.1.0", confirmed)
scenario("crash", CRASHES, "1.1.0", crashed)
scenario("power loss", HANGS, "1.1.0", power_loss)

def keys(work, name):
    secret, public = os.path.join(work, name + ".key"), os.path.join(work, name + ".pub")
    subprocess.run([HOST_ID, "image", "keygen", "--secret", secret, "--public", public],
                   check=True, capture_output=True)
    return secret, public


def boot_until(work, extra, needle):
    """delta_boot until `needle` (or its end), then stopped; what it said."""
    boot = Boot(work, extra)
    boot.wait_for(needle)
    boot.stop()
    return boot.log


def boot_ends(work, extra):
    """delta_boot that ends by itself: its exit code and what it said."""
    p = subprocess.run([DELTA_BOOT, "--state-dir", os.path.join(work, "state")] + extra,
                       capture_output=True, text=True, timeout=60,
                       env=dict(os.environ, FIFO=os.path.join(work, "fifo"),
                                STATE_LOG=os.path.join(work, "started.log")))
    return p.returncode, p.stderr


# The public key is installed once (docs/security.md): the first --public-key
# goes into the state folder and holds without the option; another key is
# refused; --replace-public-key, the local procedure, replaces it, and then
# the images signed with the old key no longer start.
with tempfile.TemporaryDirectory() as work:
    os.mkdir(os.path.join(work, "state"))
    os.mkfifo(os.path.join(work, "fifo"))
    secret_a, public_a = keys(work, "a")
    _, public_b = keys(work, "b")
    v1 = make_image(work, "v1", V1, "1.0.0")
    subprocess.run([HOST_ID, "image", "sign", v1, "--key", secret_a], check=True,
                   capture_output=True)
    log = boot_until(work, ["--install", v1, "--public-key", public_a], "started slot 0")
    check("installed public key" in log and "started slot 0" in log, "key installed\n" + log)
    with open(os.path.join(work, "state", "public.key")) as f, open(public_a) as g:
        check(f.read() == g.read(), "state/public.key is the given key")
    log = boot_until(work, [], "started slot 0")
    check("must be signed with the public key installed in" in log and "started slot 0" in log,
          "the installed key holds without --public-key\n" + log)
    code, log = boot_ends(work, ["--public-key", public_b])
    check(code == 2 and "is another" in log and "--replace-public-key" in log,
          "another key refused: %r\n%s" % (code, log))
    code, log = boot_ends(work, ["--replace-public-key", public_b])
    check("public key replaced (" in log and "by the local procedure" in log,
          "the local procedure replaces it\n" + log)
    check(code == 7 and "started slot 0" not in log,
          "an image signed with the old key no longer starts: %r\n%s" % (code, log))

def key_image(work, name, public, secret=None):
    """A key image of `public` (host_id image key), signed with `secret`."""
    image = os.path.join(work, name + ".img")
    subprocess.run([HOST_ID, "image", "key", public, "-o", image, "--version", "1.0.0"],
                   check=True, capture_output=True)
    if secret:
        subprocess.run([HOST_ID, "image", "sign", image, "--key", secret], check=True,
                       capture_output=True)
    return image


# A key image (docs/security.md) replaces the installed key only when it is
# signed with it: one signed with another key and an unsigned one are
# refused, the key stays; one signed with the installed key installs its
# key, the program restarts, the slot the old key vouched for still starts
# (also after a restart), and from then on only images signed with the new
# key are taken.
with tempfile.TemporaryDirectory() as work:
    os.mkdir(os.path.join(work, "state"))
    os.mkfifo(os.path.join(work, "fifo"))
    secret_a, public_a = keys(work, "a")
    secret_b, public_b = keys(work, "b")
    secret_c, _ = keys(work, "c")
    v1 = make_image(work, "v1", V1, "1.0.0")
    subprocess.run([HOST_ID, "image", "sign", v1, "--key", secret_a], check=True,
                   capture_output=True)
    installed = os.path.join(work, "state", "public.key")
    boot = Boot(work, ["--install", v1, "--public-key", public_a, "--trial-timeout", "2"])
    check(boot.wait_for("started slot 0 (version 1.0.0"), "key image: v1 starts\n" + boot.log)
    for name, secret, why in (("by-c", secret_c, "image signature does not verify"),
                              ("unsigned", None, "image is not signed")):
        command(work, "stage " + key_image(work, name, public_b, secret))
        check(boot.wait_for("refused the key image: " + why),
              "key image %s refused\n%s" % (name, boot.log))
        with open(installed) as f, open(public_a) as g:
            check(f.read() == g.read(), "key image %s: the installed key stays" % name)
    command(work, "stage " + key_image(work, "by-a", public_b, secret_a))
    check(boot.wait_for("by a key image signed with the old key"), "key image taken\n" + boot.log)
    check(boot.wait_for("restarting the program\ndelta_boot: started slot 0 (version 1.0.0"),
          "the program restarts, the old key's slot still starts\n" + boot.log)
    with open(installed) as f, open(public_b) as g:
        check(f.read() == g.read(), "state/public.key is the key image's")
    v2_old = make_image(work, "v2-old", CONFIRMS, "1.1.0")
    subprocess.run([HOST_ID, "image", "sign", v2_old, "--key", secret_a], check=True,
                   capture_output=True)
    command(work, "stage " + v2_old)
    check(boot.wait_for("refused the downloaded image: "), "old key's image refused\n" + boot.log)
    v2_new = make_image(work, "v2-new", CONFIRMS, "1.1.0")
    subprocess.run([HOST_ID, "image", "sign", v2_new, "--key", secret_b], check=True,
                   capture_output=True)
    command(work, "stage " + v2_new)
    check(boot.wait_for("staged slot 1 (version 1.1.0"), "new key's image staged\n" + boot.log)
    boot.stop()
    log = boot_until(work, [], "started slot 0")
    check("started slot 0 (version 1.0.0" in log, "after a restart slot 0 still starts\n" + log)
    # A service file written before still gives the old key: taken as the
    # installed one's, with a note; a key image is no program to install.
    log = boot_until(work, ["--public-key", public_a], "started slot 0")
    check("was replaced by the installed key" in log and "started slot 0 (version 1.0.0" in log,
          "the old --public-key still starts\n" + log)
    rotate = key_image(work, "by-a2", public_b, secret_a)
    with tempfile.TemporaryDirectory() as fresh:
        os.mkdir(os.path.join(fresh, "state"))
        code, log = boot_ends(fresh, ["--install", rotate])
        check(code == 7 and "is a key image, not a program" in log,
              "a key image is no program to install: %r\n%s" % (code, log))

with tempfile.TemporaryDirectory() as work:
    os.mkdir(os.path.join(work, "state"))
    p = subprocess.run([DELTA_BOOT, "--state-dir", os.path.join(work, "state")],
                       capture_output=True, text=True)
    check(p.returncode == 7 and "holds no program: give one with --install IMAGE" in p.stderr,
          "empty folder: %d %s" % (p.returncode, p.stderr))
    with open(os.path.join(work, "state", "boot.record"), "wb") as f:
        f.write(b"DBR1" + bytes(32))
    p = subprocess.run([DELTA_BOOT, "--state-dir", os.path.join(work, "state")],
                       capture_output=True, text=True)
    check(p.returncode == 7 and "boot.record: not a valid boot record" in p.stderr,
          "corrupt record: %d %s" % (p.returncode, p.stderr))

if failures:
    sys.exit("%d check(s) failed" % len(failures))
print("delta_boot: confirm, crash, power loss, the public key installed once and replaced by a "
      "key image signed with it, empty folder and corrupt record behave as documented")
