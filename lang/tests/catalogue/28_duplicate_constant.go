// The same constant declared twice, and a constant named like a drone.
package DuplicateConst

const (
	Side   = 2
	Height = 1.5
	Side   = 3
)

const Drone1 = 4

var Drone1 Quadcopter

func INIT() {
	Drone1.Takeoff(Height)
}
