// Only one branch of an If takes D1 across D2's path.
package Branch

var (
	D1 Quadcopter
	D2 Quadcopter
)

func SEQ_Mission() {
	PAR_Up()
	PAR_Fly()
	PAR_Down()
}

func PAR_Up() {
	SEQ_Up1()
	SEQ_Up2()
}

func SEQ_Up1() {
	D1.Arm()
	D1.Takeoff(5)
}

func SEQ_Up2() {
	D2.Arm()
	D2.Takeoff(5)
}

func PAR_Fly() {
	If(D1.Battery() > 50, SEQ_Across, SEQ_Away)
	D2.FlyByX(10)
}

func SEQ_Across() {
	D1.FlyTo(5, 3, 5)
}

func SEQ_Away() {
	D1.FlyByY(-3)
}

func PAR_Down() {
	D1.Land()
	D2.Land()
}
