#!/usr/bin/env python3
"""Writes the seed corpus of fuzz_script (tests/fuzz/corpus_script/seed_*): the demo --script files
the tests use (tests/demo_window.sh, tests/demo_matches_render.sh), one file per command with
each form it takes (apps/demo/demo.h), and a few that the parser must refuse. Deterministic. Run from
anywhere:
    python3 tests/fuzz/make_corpus_script.py
Crash reproducers (regress_*) are not touched.
"""
import os

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "corpus_script")

# tests/demo_window.sh's script, as it runs (SHOT replaced), read from the test itself so that the
# seed follows it.
with open(os.path.join(HERE, "..", "demo_window.sh")) as f:
    _test = f.read()
DEMO_WINDOW = _test.split("<<'SCRIPT'\n", 1)[1].split("\nSCRIPT\n", 1)[0] + "\n"
DEMO_WINDOW = DEMO_WINDOW.replace("SHOT", "/tmp/demo_window/frame29.png")

SEEDS = {
    "seed_demo_window": DEMO_WINDOW,
    # tests/demo_matches_render.sh: a move and a screenshot; its two refused scripts
    "seed_move_object": "frame 1 move-object 1 0.15 0 0\nframe 2 screenshot objects_ground.demo.png\n",
    "seed_move_object_far": "frame 1 move-object 3 0.1 0 0\n",
    "seed_move_object_short": "# comment\nframe 1 move-object 1 0.1 0\n",
    # one command per file, each form
    "seed_key": "frame 0 key M\n",
    "seed_key_shift": "frame 3 key shift+n\nframe 3 key SHIFT+Pageup\n",
    "seed_key_named": "frame 1 key left\nframe 1 key right\nframe 2 key up\nframe 2 key down\n"
                      "frame 3 key pageup\nframe 3 key pagedown\nframe 4 key space\nframe 5 key escape\n",
    "seed_key_punctuation": "frame 0 key ,\nframe 0 key -\nframe 0 key .\nframe 0 key /\nframe 0 key ;\n"
                            "frame 0 key =\nframe 0 key [\nframe 0 key ]\nframe 0 key `\nframe 0 key '\n",
    "seed_orbit": "frame 2 orbit -45.5 1e1\n",
    "seed_pan": "frame 0 pan 0.25 -0.125\n",
    "seed_zoom": "frame 7 zoom 1.25\nframe 8 zoom 1e-3\n",
    "seed_resize": "frame 4294967295 resize 16384 1\n",
    "seed_screenshot": "frame 9 screenshot shot.png\n",
    # layout: out of order (sorted by frame, then line), tabs, CRLF, a last line without newline
    "seed_layout": "\n  # header\n\tframe 5 key B\r\nframe 1 zoom 2 # trailing\r\n\nframe 1 key A\nframe 0 key Z",
    # refused
    "seed_bad_words": "frame 1 move-object 1 2 3 4 5\n",
    "seed_bad_frame": "frame -1 key M\n",
    "seed_bad_number": "frame 1 orbit nan 1\n",
    "seed_bad_command": "frame 1 jump 2\n",
}


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, text in SEEDS.items():
        with open(os.path.join(OUT, name), "wb") as f:
            f.write(text.encode())
        print(f"{name}: {len(text)} bytes")


if __name__ == "__main__":
    main()
