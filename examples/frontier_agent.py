"""A frontier explorer for mazeslam/Maze-v0: it learns the maze's passages from its laser scans and
always heads for the nearest cell it has seen an opening to but not yet entered.

At each cell centre it looks along the four grid directions: a beam that reaches farther than
the cell's edge means an opening. Known openings form a graph of cells; the frontier is the
openings' far cells not yet visited; the agent drives (breadth-first shortest path over known
openings) to the nearest one. It localises by the true pose in ``info`` (swap in
``info["slam"]["pose"]`` from ``mazeslam.envs.online_slam.OnlineFastSLAM`` for an agent that only
trusts itself).
With ``--record`` the episode is written as a course log with truth and map sidecars:

    python examples/frontier_agent.py --record runs/frontier.log
    mazeslam slam runs/frontier.log

``--render`` shows the agent in a window as it drives; ``--video runs/videos`` writes an MP4 of the
episode (Gymnasium's RecordVideo; needs ``pip install 'mazeslam[video]'``, which brings moviepy).
"""

import argparse
from collections import deque

import gymnasium as gym
import numpy as np
from tqdm.auto import tqdm

import mazeslam  # noqa: F401  (registers the environments)
from mazeslam.envs.wrappers import RecordCourseLog
from mazeslam.sim.policies import DriveParams, steer_to
from mazeslam.viz import backends

DIRECTIONS = {(0, 1): 0.0, (1, 0): np.pi / 2, (0, -1): np.pi, (-1, 0): -np.pi / 2}  # (d_row, d_col): world angle


class FrontierAgent:
    def __init__(self, env, drive: DriveParams = DriveParams()):
        base = env.unwrapped
        self.maze_size = (base.maze.rows, base.maze.cols)
        self.cell_size = base.maze.cell_size
        self.bearings = base.laser.bearings
        self.top_speed, self.top_turn = base.config.robot.max_wheel_speed, base.top_turn_rate
        self.drive = drive
        self.openings: dict[tuple, set] = {}
        self.visited: set = set()
        self.path: deque = deque()

    def cell_of(self, pose):
        row = int(np.clip(pose[1] // self.cell_size, 0, self.maze_size[0] - 1))
        col = int(np.clip(pose[0] // self.cell_size, 0, self.maze_size[1] - 1))
        return row, col

    def centre(self, cell):
        return (np.array([cell[1], cell[0]]) + 0.5) * self.cell_size

    def _look(self, cell, pose, scan):
        """Record the openings of ``cell`` seen from its centre."""
        opens = self.openings.setdefault(cell, set())
        for (d_row, d_col), angle in DIRECTIONS.items():
            beam = int(np.argmin(np.abs(np.angle(np.exp(1j * (self.bearings - (angle - pose[2])))))))
            reach = scan[beam]
            if reach == 0 or reach > 0.8 * self.cell_size:
                neighbour = (cell[0] + d_row, cell[1] + d_col)
                if 0 <= neighbour[0] < self.maze_size[0] and 0 <= neighbour[1] < self.maze_size[1]:
                    opens.add(neighbour)
                    self.openings.setdefault(neighbour, set()).add(cell)

    def _plan(self, start):
        """Shortest path over known openings to the nearest unvisited cell."""
        previous, queue = {start: None}, deque([start])
        while queue:
            cell = queue.popleft()
            if cell not in self.visited:
                path = [cell]
                while previous[path[-1]] is not None:
                    path.append(previous[path[-1]])
                return deque(path[::-1][1:])
            for neighbour in self.openings.get(cell, ()):
                if neighbour not in previous:
                    previous[neighbour] = cell
                    queue.append(neighbour)
        return deque()

    def __call__(self, observation, info) -> np.ndarray:
        pose = info["pose"]
        cell = self.cell_of(pose)
        at_centre = np.hypot(*(self.centre(cell) - pose[:2])) < self.drive.waypoint_tolerance
        if at_centre and cell not in self.visited:
            self.visited.add(cell)
            self._look(cell, pose, np.asarray(observation["scan"], dtype=float))
        if self.path and self.path[0] == cell and at_centre:
            self.path.popleft()
        if not self.path:
            self.path = self._plan(cell) if cell in self.visited else deque([cell])
        target = self.centre(self.path[0]) if self.path else self.centre(cell)
        speed, turn = steer_to(pose, target, self.drive)
        return np.array([speed / self.top_speed, turn / self.top_turn], dtype=np.float32)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rows", type=int, default=4)
    parser.add_argument("--cols", type=int, default=4)
    parser.add_argument("--record", help="write the episode as a course log here (sidecars beside it)")
    parser.add_argument("--render", action="store_true", help="show the agent in a window as it drives")
    parser.add_argument(
        "--video",
        metavar="FOLDER",
        help="record the episode as an MP4 into FOLDER (needs moviepy: pip install 'mazeslam[video]')",
    )
    args = parser.parse_args()
    render_mode, note = backends.render_mode(args.render, bool(args.video))
    if note:
        print(note)
    env = gym.make(
        "mazeslam/Maze-v0", rows=args.rows, cols=args.cols, max_episode_steps=args.steps, render_mode=render_mode
    )
    if args.video:
        env = gym.wrappers.RecordVideo(env, args.video, name_prefix="frontier_agent", disable_logger=True)
    if args.record:
        env = RecordCourseLog(env, args.record)
    observation, info = env.reset(seed=args.seed)
    agent = FrontierAgent(env)
    total, steps_taken = 0.0, 0
    for _ in tqdm(range(args.steps), desc="steps", unit="step", leave=False):
        observation, reward, terminated, truncated, info = env.step(agent(observation, info))
        steps_taken += 1
        total += reward
        if terminated or truncated:
            break
    env.close()
    print(
        f"frontier agent: {steps_taken} steps ({info['time']:.0f} s), reward {total:.1f}, cells visited "
        f"{info['visited']:.0%}, walls seen {info['coverage']:.0%}" + (f"; log: {args.record}" if args.record else "")
    )


if __name__ == "__main__":
    main()
