// Three drones, one of which waits on another: what happens when a drone
// is lost depends on who waits on it. Free flies on its own; Follow sets
// off on its second leg only once Lead has reached the far end of its leg.
// Lose Lead and Free carries on untouched, while Follow follows the policy
// its fleet file declares (see dropout_fleet.toml).
package Dropout

var (
	Free   Quadcopter
	Lead   Quadcopter
	Follow Quadcopter
)

func PAR_Mission() {
	SEQ_Free()
	SEQ_Lead()
	SEQ_Follow()
}

func SEQ_Free() {
	Free.Arm()
	Free.Takeoff(3)
	Free.FlyByX(20)
	Free.FlyByX(-20)
	Free.Land()
}

func SEQ_Lead() {
	Lead.Arm()
	Lead.Takeoff(3)
	Lead.FlyByX(100)
	Signal("there")
	Lead.Land()
}

func SEQ_Follow() {
	Follow.Arm()
	Follow.Takeoff(4)
	Follow.FlyByY(5)
	Await("there")
	Follow.FlyByX(20)
	Follow.Land()
}
