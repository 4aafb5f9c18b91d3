#!/usr/bin/env python3
"""slow_copy.py INPUT OUTPUT: the identity "method" with a delay (SLOW_COPY_DELAY_S seconds, default
1), used by test_local.sh so that an array task is still running when the test requeues it."""
import os
import shutil
import sys
import time

if len(sys.argv) != 3:
    sys.exit("usage: slow_copy.py INPUT OUTPUT")
time.sleep(float(os.environ.get("SLOW_COPY_DELAY_S", "1")))
shutil.copyfile(sys.argv[1], sys.argv[2])
