"""A random agent in mazeslam/Maze-v0: how much of the maze does chance explore?

    python examples/random_agent.py [--steps 2000] [--seed 0] [--render] [--video runs/videos]

--render shows the agent in a window as it drives; --video writes an MP4 of the episode into that
folder (Gymnasium's RecordVideo; needs `pip install 'mazeslam[video]'`, which brings moviepy).
"""

import argparse

import gymnasium as gym
from tqdm.auto import tqdm

import mazeslam  # noqa: F401  (registers the environments)
from mazeslam.viz import backends


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--render", action="store_true", help="show the agent in a window as it drives")
    parser.add_argument("--video", metavar="FOLDER", help="record the episode as an MP4 into FOLDER (needs moviepy)")
    args = parser.parse_args()
    render_mode, note = backends.render_mode(args.render, bool(args.video))
    if note:
        print(note)
    env = gym.make("mazeslam/Maze-v0", max_episode_steps=args.steps, render_mode=render_mode)
    if args.video:
        env = gym.wrappers.RecordVideo(env, args.video, name_prefix="random_agent", disable_logger=True)
    env.action_space.seed(args.seed)
    observation, info = env.reset(seed=args.seed)
    total, collisions, steps_taken = 0.0, 0, 0
    for _ in tqdm(range(args.steps), desc="steps", unit="step", leave=False):
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        steps_taken += 1
        total += reward
        collisions += info["collision"]
        if terminated or truncated:
            break
    env.close()
    print(
        f"random agent: {steps_taken} steps, reward {total:.1f}, cells visited {info['visited']:.0%}, "
        f"walls seen {info['coverage']:.0%}, steps touching a wall {collisions}"
    )


if __name__ == "__main__":
    main()
