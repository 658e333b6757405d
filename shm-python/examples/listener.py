"""Receive camera frames and read them as numpy arrays, without a copy.

    python listener.py [count]
"""

import sys

import shm_cdr

count = int(sys.argv[1]) if len(sys.argv) > 1 else None
node = shm_cdr.Node("listener")
subscription = node.create_subscription("sensor_msgs/msg/Image", "camera/image")

for received, image in enumerate(subscription, start=1):
    # A read-only view of the publisher's shared memory: nothing was copied.
    pixels = image.data.reshape(image.height, image.width, 3)
    print(
        f"frame {image.header.stamp.sec}: {image.width}x{image.height}, "
        f"mean {pixels.mean():.0f}, in shared memory: {image.memory.is_shm}",
        flush=True,
    )
    if received == count:
        break
