// The same drone declared twice (once in a group).
package DuplicateDrone

var Drone1 Quadcopter
var (
	Drone2 Quadcopter
	Drone1 Quadcopter
)

func INIT() {
	Drone1.Arm()
	Drone2.Arm()
}
